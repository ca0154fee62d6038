"""Fuzzer speed: cases per second in-process and over UDP to a node process.

Each campaign runs with the default oracles (a liveness probe after every
case, a read-back after every write, a register sweep every 64 cases) and no
shrinking; the rate counts cases only, not start-up. Baselines measured in the
same run: the case generator alone, and one bare responder answering the same
cases (the least a fuzzer with a reference model must spend is two of those).
Targets: >= 5,000 cases/s in-process, >= 1,500 cases/s over UDP, >= 100 cases/s
for the thesis link RTL in Icarus Verilog (``rtl:thesis``; skipped without
iverilog and cocotb), run interleaved with ``inproc:snake2010`` on the same
seeds as its baseline.

    python bench/fuzz.py [--cases 20000] [--remote-cases 5000] [--rtl-cases 1000]
    python bench/fuzz.py --jobs-only [--jobs-cases 200000] [--jobs-rounds 5]
    python bench/fuzz.py --rtl-only [--rtl-cases 1000]
    python bench/fuzz.py --cluster-only [--rtl-cases 1000]

``--jobs 2`` against one job: the same in-process campaign (the same total
cases, seeds derived from one) timed from start to merged report, process
start-up included, in interleaved rounds; the ratio of cases/s is the
speed-up (target >= 1.7 on 2 cores; the load average is printed with it).
"""

from __future__ import annotations

import argparse
import os
import random
import subprocess
import sys
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from contextlib import AbstractContextManager, contextmanager
from typing import Any

from fw1394.engine import Responder
from fw1394.fuzz.campaign import run
from fw1394.fuzz.contract import CONTRACTS
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.reference import board
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.workers import run as run_jobs
from fw1394.transport.supervision.stop import stop

NODE = 0xFFC0
IN_PROCESS_TARGET = 5_000
UDP_TARGET = 1_500
JOBS_TARGET = 1.7
RTL_TARGET = 100
#: Two Dask workers against one, rtl:thesis (the cluster's speed-up).
CLUSTER_TARGET = 1.6
KINDS = ("memory", "qla1", "snake2010")


def generator_rate(kind: str, cases: int) -> float:
    generator = Generator(NODE, offset_model(kind), random.Random(0))
    start = time.perf_counter()
    for _ in range(cases):
        generator.case()
    return cases / (time.perf_counter() - start)


def responder_rate(kind: str, cases: int) -> float:
    generator = Generator(NODE, offset_model(kind), random.Random(0))
    raws = [generator.case()[0] for _ in range(cases)]
    responder = Responder(NODE, board(kind, 0), CONTRACTS["thesis"])
    start = time.perf_counter()
    for number, raw in enumerate(raws):
        responder.receive(raw, number * 20e-6)
    return cases / (time.perf_counter() - start)


def campaign_rate(target: str, cases: int, **options: object) -> tuple[float, int]:
    report = run(Settings(target, max_cases=cases, shrink_budget=0, **options))  # type: ignore[arg-type]
    return report.rate, len(report.findings)


@contextmanager
def child(*command: str) -> Iterator[subprocess.Popen[str]]:
    process = subprocess.Popen(
        [sys.executable, "-m", *command],
        stdout=subprocess.PIPE,
        stdin=subprocess.DEVNULL,
        text=True,
    )
    try:
        yield process
    finally:
        stop(process)
        if process.stdout is not None:
            process.stdout.close()


def served(kind: str, *extra: str) -> AbstractContextManager[subprocess.Popen[str]]:
    return child(
        "fw1394.cli.main", "fuzz", "serve", kind, "--listen", "127.0.0.1:0",
        "--duration", "600", "--parent-pid", str(os.getpid()), *extra,
    )  # fmt: skip


def listening(process: subprocess.Popen[str]) -> str:
    assert process.stdout is not None
    return process.stdout.readline().strip().removeprefix("listening on ")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cases", type=int, default=20_000, help="cases per in-process run")
    parser.add_argument("--remote-cases", type=int, default=5_000, help="cases per remote run")
    parser.add_argument("--jobs-cases", type=int, default=200_000, help="cases per jobs run")
    parser.add_argument("--jobs-rounds", type=int, default=3, help="interleaved jobs rounds")
    parser.add_argument("--jobs-only", action="store_true", help="only --jobs 2 against 1")
    parser.add_argument("--rtl-cases", type=int, default=1_000, help="cases per RTL run (0: skip)")
    parser.add_argument("--rtl-only", action="store_true", help="only the RTL target")
    parser.add_argument(
        "--cluster-only", action="store_true", help="only rtl:thesis on 2 Dask workers against 1"
    )
    args = parser.parse_args()
    if args.cluster_only:
        cluster_speedup(args.rtl_cases)
        return
    if args.jobs_only:
        jobs_speedup(args.jobs_cases, args.jobs_rounds)
        return
    print(f"{'target':34} {'cases/s':>8} {'target':>7}  baselines (same run)")
    if args.rtl_only:
        rtl_rates(args.rtl_cases)
        return
    worst_local = float("inf")
    for kind in KINDS:
        rate, _ = campaign_rate(
            f"inproc:{kind}", args.cases, contract="jhu" if kind == "qla1" else "thesis"
        )
        worst_local = min(worst_local, rate)
        generated = generator_rate(kind, args.cases)
        answered = responder_rate(kind, args.cases)
        print(
            f"{'inproc:' + kind:34} {rate:8,.0f} {IN_PROCESS_TARGET:7,}  "
            f"generator {generated:,.0f}/s, one responder {answered:,.0f}/s"
        )
    remote = remote_rates(args.remote_cases)
    for label, rate in remote:
        print(f"{label:34} {rate:8,.0f} {UDP_TARGET:7,}")
    udp = min(rate for label, rate in remote if label.startswith("udp"))
    local = verdict(worst_local, IN_PROCESS_TARGET)
    print(f"\nin-process: slowest {worst_local:,.0f} cases/s ({local})")
    print(f"over UDP:   slowest {udp:,.0f} cases/s ({verdict(udp, UDP_TARGET)})")
    if args.rtl_cases:
        print()
        rtl_rates(args.rtl_cases)
    print()
    jobs_speedup(args.jobs_cases, args.jobs_rounds)


def jobs_rate(jobs: int, cases: int) -> float:
    """Cases/s of one in-process campaign on ``jobs`` workers, start-up included."""
    settings = Settings("inproc:memory", max_cases=cases, shrink_budget=0, seed=1)
    start = time.perf_counter()
    report = run_jobs(settings, jobs)
    return report.cases / (time.perf_counter() - start)


def _burn(loops: int) -> int:
    total = 0
    for number in range(loops):
        total += number
    return total


def machine_parallelism(loops: int = 5_000_000) -> float:
    """What two processes get done against one right now (a bare loop): the ceiling
    of any speed-up from workers while other work shares the machine."""
    start = time.perf_counter()
    _burn(2 * loops)
    one = time.perf_counter() - start
    with ProcessPoolExecutor(2) as pool:
        start = time.perf_counter()
        list(pool.map(_burn, [loops, loops]))
        two = time.perf_counter() - start
    return one / two


def jobs_speedup(cases: int, rounds: int) -> None:
    """``--jobs 2`` against one job, interleaved rounds; the median ratio."""
    ratios, ceilings = [], []
    print(f"--jobs 2 vs 1, inproc:memory, {cases:,} cases a run, {os.cpu_count()} CPUs")
    for number in range(1, rounds + 1):
        one = jobs_rate(1, cases)
        two = jobs_rate(2, cases)
        ceiling = machine_parallelism()
        ratios.append(two / one)
        ceilings.append(ceiling)
        load = ", ".join(f"{value:.1f}" for value in os.getloadavg())
        print(
            f"  round {number}: 1 job {one:8,.0f} cases/s, 2 jobs {two:8,.0f} cases/s, "
            f"ratio {two / one:.2f}; bare loop 2 vs 1 process {ceiling:.2f} "
            f"(load average {load})"
        )
    median = sorted(ratios)[len(ratios) // 2]
    ceiling = sorted(ceilings)[len(ceilings) // 2]
    met = "met" if median >= JOBS_TARGET else "NOT met"
    print(
        f"median ratio {median:.2f}, machine ceiling {ceiling:.2f} "
        f"(target >= {JOBS_TARGET} on 2 idle cores: {met})"
    )


def rtl_rates(cases: int) -> None:
    """The thesis RTL (rtl:thesis) beside inproc:snake2010, three interleaved rounds."""
    from fw1394.rtl.simulation import missing_tools

    problem = missing_tools()
    if problem:
        print(f"{'rtl:thesis':34} skipped: {problem}")
        return
    rtl, emulated = [], []
    for seed in range(3):
        rtl.append(campaign_rate("rtl:thesis", cases, seed=seed)[0])
        emulated.append(campaign_rate("inproc:snake2010", cases, seed=seed)[0])
    rate, baseline = sorted(rtl)[1], sorted(emulated)[1]
    print(
        f"{'rtl:thesis (Icarus + cocotb)':34} {rate:8,.0f} {RTL_TARGET:7,}  "
        f"inproc:snake2010 {baseline:,.0f}/s, ratio {baseline / rate:,.0f}x"
    )
    print(f"RTL:        median of 3 {rate:,.0f} cases/s ({verdict(rate, RTL_TARGET)})")


def cluster_speedup(cases: int) -> None:
    """rtl:thesis on a 2-worker Dask LocalCluster against one worker, interleaved rounds,
    timed from submission to merged report (cluster start-up excluded). From the second
    round on, both start on the simulation the last round parked (as a long-lived
    worker does); what two bare processes get done against one right now is printed
    beside each round (the ceiling of any speed-up on a shared machine)."""
    from distributed import LocalCluster

    from fw1394.fuzz import cluster, workers
    from fw1394.fuzz.settings import Settings

    one, two = [], []
    start_cluster: Any = LocalCluster  # (distributed ships no type hints)
    with start_cluster(
        n_workers=2, threads_per_worker=1, host="127.0.0.1", dashboard_address=None
    ) as local:
        for seed in range(3):
            settings = Settings("rtl:thesis", seed=seed, max_cases=cases, shrink_budget=0)
            start = time.perf_counter()
            workers.run(settings, 1)
            one.append(cases / (time.perf_counter() - start))
            start = time.perf_counter()
            cluster.run(settings, local.scheduler_address)
            two.append(cases / (time.perf_counter() - start))
            print(
                f"  round {seed + 1}: 1 worker {one[-1]:.1f} cases/s, 2 workers "
                f"{two[-1]:.1f} cases/s, {two[-1] / one[-1]:.2f}x; bare loop 2 vs 1 process "
                f"{machine_parallelism():.2f} (load average {os.getloadavg()[0]:.1f})"
            )
    alone, spread = sorted(one)[1], sorted(two)[1]
    print(
        f"rtl:thesis, {cases} cases a round: 1 worker {alone:.1f} cases/s, 2 Dask workers "
        f"{spread:.1f} cases/s: {spread / alone:.2f}x (target >= {CLUSTER_TARGET}); "
        f"load average {os.getloadavg()[0]:.1f}"
    )


def verdict(rate: float, target: int) -> str:
    return f"target >= {target:,}: {'met' if rate >= target else 'NOT met'}"


def remote_rates(cases: int) -> list[tuple[str, float]]:
    """Campaigns against node processes: fuzz serve over both framings, and a bus node."""
    rates = []
    runs: list[tuple[str, str, tuple[str, ...], dict[str, object]]] = [
        ("udp (tunnel) -> fuzz serve memory", "memory", (), {"model": "memory"}),
        ("udp (eth1394) -> fuzz serve memory", "memory", ("--eth1394",), {"model": "memory"}),
        ("udp (tunnel) -> fuzz serve qla1", "qla1", ("--policy", "jhu"), {"model": "qla1"}),
    ]
    for label, kind, serve_options, options in runs:
        if "--eth1394" in serve_options:
            options["eth1394"] = True
        if kind == "qla1":
            options["contract"] = "jhu"
        with served(kind, *serve_options) as node:
            rates.append((label, campaign_rate(f"udp:{listening(node)}", cases, **options)[0]))
    name = f"bench-fuzz-{os.getpid()}"
    bus_node = (
        "fw1394.cli.bus", "node", "run", "--name", name, "--rank", "0", "--policy", "thesis",
        "--parent-pid", str(os.getpid()), "--quiet",
    )  # fmt: skip
    with child(*bus_node):
        rate = campaign_rate(f"bus:{name}/0", cases, model="memory", timeout=1.0)[0]
    rates.append(("bus: -> node run memory", rate))
    return rates


if __name__ == "__main__":
    main()
