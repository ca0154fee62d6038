"""A blocking raw1394_read of a quadlet through fw1394's libraw1394, next to AdapterPort.

    python bench/raw1394_read.py               # 8 rounds of 2000 reads each way
    python bench/raw1394_read.py --rounds 4 --reads 500 --json
    python bench/raw1394_read.py --rt          # the JHU-style loop, 4 boards
    nice -n 10 python bench/raw1394_read.py --rt --rounds 6 --before main
    python bench/raw1394_read.py --rt --idle block   # no process polls: CPU of the work alone


Starts a bus of one memory board with its host adapter (in a private runtime
directory), builds the library, and times quadlet reads of the board in
interleaved rounds: AdapterPort.read_quadlet from this process, then a small C
program (built here against the system's libraw1394 headers, run with the
library in place) calling raw1394_read in a loop, then AdapterPort again...
Each side times only its loop (the C program reports its own clock), so
process start-up is not counted. The ratio library / AdapterPort per round and
their median are printed; the issue's goal is <= 1.3x. ``--rt`` instead runs the
JHU host library's real-time loop shape through the library (per cycle, one
64-byte block read and one 16-byte block write per board, four boards) and
prints cycles per second (goal >= 1 kHz). Nothing is asserted. With
``--before REF`` each round runs the loop once on a git worktree of REF (the
baseline) and once on this checkout, in a fresh bus each, alternating which goes
first (ABAB), and prints the per-round ratio this / REF.
The machine this runs on may be shared: compare ratios of one run, not
absolute times across runs.

The bus's processes (nodes, adapter) wait as ``FW1394_IDLE`` says (``--idle``
sets it): adaptive by default, polling for a while after traffic while every
runnable task has a CPU, which on a loaded machine means blocking; the C program
sleeps until each reply (the library never polls). CPU per transaction is
reported for the adapter, the nodes and the program; under a polling strategy it
includes the polling.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import resource
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from pathlib import Path

from fw1394.host.adapter_port import AdapterPort
from fw1394.raw1394.launch import environment
from fw1394.transport.host_adapter.server import adapter_pid, wait_adapter
from fw1394.transport.media.idle import ENVIRONMENT as IDLE_VARIABLE
from fw1394.transport.media.idle import default_idle, parse_idle
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

PROGRAM = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <libraw1394/raw1394.h>
int main(int argc, char **argv)
{
	int reads = atoi(argv[1]), i;
	quadlet_t value;
	struct timespec a, b;
	raw1394handle_t h = raw1394_new_handle_on_port(0);
	if (!h) { perror("raw1394_new_handle_on_port"); return 1; }
	for (i = 0; i < 20; i++) raw1394_read(h, 0xFFC0, 0, 4, &value); /* warm up */
	clock_gettime(CLOCK_MONOTONIC, &a);
	for (i = 0; i < reads; i++)
		if (raw1394_read(h, 0xFFC0, 0, 4, &value) < 0) { perror("raw1394_read"); return 1; }
	clock_gettime(CLOCK_MONOTONIC, &b);
	printf("%.0f\n", ((b.tv_sec - a.tv_sec) * 1e9 + (b.tv_nsec - a.tv_nsec)) / reads);
	raw1394_destroy_handle(h);
	return 0;
}
"""


RT_PROGRAM = r"""
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
#include <libraw1394/raw1394.h>
int main(int argc, char **argv)
{
	int cycles = atoi(argv[1]), boards = atoi(argv[2]), i, b;
	quadlet_t in[16], out[4] = { 0 };
	struct timespec a, z;
	raw1394handle_t h = raw1394_new_handle_on_port(0);
	if (!h) { perror("raw1394_new_handle_on_port"); return 1; }
	clock_gettime(CLOCK_MONOTONIC, &a);
	for (i = 0; i < cycles; i++)
		for (b = 0; b < boards; b++) {
			out[0] = i;
			if (raw1394_read(h, 0xFFC0 | b, 0, sizeof in, in) < 0 ||
				raw1394_write(h, 0xFFC0 | b, 0x100, sizeof out, out) < 0) {
				perror("transaction"); return 1;
			}
		}
	clock_gettime(CLOCK_MONOTONIC, &z);
	printf("%.1f\n", cycles / ((z.tv_sec - a.tv_sec) + (z.tv_nsec - a.tv_nsec) / 1e9));
	raw1394_destroy_handle(h);
	return 0;
}
"""


def adapter_port_round(port: AdapterPort, reads: int) -> float:
    for _ in range(20):
        port.read_quadlet(0, 0)
    start = time.perf_counter_ns()
    for _ in range(reads):
        port.read_quadlet(0, 0)
    return (time.perf_counter_ns() - start) / reads


def library_round(program: Path, env: dict[str, str], reads: int) -> float:
    out = subprocess.run(
        [str(program), str(reads)], env=env, capture_output=True, text=True, check=True
    )
    return float(out.stdout)


HERE = Path(__file__).resolve().parents[1]


@contextlib.contextmanager
def checkout(ref: str) -> Iterator[Path]:
    """A temporary git worktree of ``ref`` (detached), removed afterwards."""
    place = Path(tempfile.mkdtemp(prefix="raw1394-before-")) / "tree"
    git = ["git", "-C", str(HERE)]
    made = subprocess.run(
        [*git, "worktree", "add", "--detach", str(place), ref], capture_output=True, text=True
    )
    if made.returncode:
        shutil.rmtree(place.parent, ignore_errors=True)
        sys.exit(f"raw1394_read.py: --before {ref}: {made.stderr.strip()}")
    try:
        yield place
    finally:
        subprocess.run([*git, "worktree", "remove", "--force", str(place)], check=True)
        shutil.rmtree(place.parent, ignore_errors=True)


def cpu_seconds(pid: int | None, user_only: bool = False) -> float:
    """User and system CPU time of process ``pid`` so far (0 if it is gone);
    ``user_only``: the user time alone (the process's own work, which the load
    sways less than the kernel's wake-ups)."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    except (OSError, IndexError):
        return 0.0
    system = 0 if user_only else int(fields[12])
    return (int(fields[11]) + system) / os.sysconf("SC_CLK_TCK")


def rt_round(root: Path, reads: int) -> tuple[float, float, float, float, float]:
    """One real-time round on a fresh bus with fw1394 from ``root``: cycles/s, the
    CPU microseconds per transaction of the adapter, the nodes and the program, and
    the adapter's user CPU alone."""
    env = {**os.environ, "PYTHONPATH": str(root)}
    script = [sys.executable, str(Path(__file__).resolve()), "--rt", "--rounds", "1"]
    script += ["--reads", str(reads), "--json"]
    # In ``root``: the bus's processes start with ``python -m``, which puts the
    # working directory ahead of PYTHONPATH, so from any other checkout they
    # would run that checkout's fw1394.
    done = subprocess.run(script, env=env, cwd=root, capture_output=True, text=True, timeout=600)
    if done.returncode:
        last = (done.stderr.strip().splitlines() or ["no output"])[-1]
        sys.exit(f"raw1394_read.py: a round with fw1394 from {root} failed: {last}")
    report = json.loads(done.stdout)
    return (
        report["cycles_per_second"][0],
        report["adapter_cpu_us_per_transaction"][0],
        report["node_cpu_us_per_transaction"][0],
        report.get("program_cpu_us_per_transaction", [0.0])[0],  # older benches: none
        report.get("adapter_user_cpu_us_per_transaction", [0.0])[0],
    )


def compare(ref: str, rounds: int, reads: int) -> int:
    with checkout(ref) as before:
        sides = {"before": before, "after": HERE}
        runs: dict[str, list[tuple[float, float, float, float, float]]] = {
            "before": [],
            "after": [],
        }
        print(f"real-time loop, 4 boards: {ref} (before) vs this checkout (after)")
        print(f"waiting: {IDLE_VARIABLE}={default_idle()} (shared machine)")
        print(
            "cycles/s, then CPU us per transaction of the adapter (its user CPU) / all nodes"
            " / the program"
        )
        for number in range(rounds):
            order = ["before", "after"] if number % 2 == 0 else ["after", "before"]
            for side in order:
                runs[side].append(rt_round(sides[side], reads))
            (b_hz, b_adapter, b_nodes, b_program, b_user) = runs["before"][-1]
            (a_hz, a_adapter, a_nodes, a_program, a_user) = runs["after"][-1]
            print(
                f"round {number}: before {b_hz:.0f} Hz {b_adapter:.0f}({b_user:.0f})/"
                f"{b_nodes:.0f}/{b_program:.0f} us, after {a_hz:.0f} Hz {a_adapter:.0f}"
                f"({a_user:.0f})/{a_nodes:.0f}/{a_program:.0f} us, rate after/before "
                f"{a_hz / b_hz:.2f} (load {os.getloadavg()[0]:.1f})"
            )
    whats = (
        "cycles/s",
        "adapter CPU us/transaction",
        "node CPU us",
        "program CPU us",
        "adapter user CPU us",
    )
    for index, what in enumerate(whats):
        before_values = [run[index] for run in runs["before"]]
        after_values = [run[index] for run in runs["after"]]
        ratios = [a / b for a, b in zip(after_values, before_values, strict=True) if b]
        print(
            f"{what}: median before {statistics.median(before_values):.0f}, after "
            f"{statistics.median(after_values):.0f}; after/before median "
            f"{statistics.median(ratios):.2f} (range {min(ratios):.2f}-{max(ratios):.2f})"
        )
    return 0


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=8)
    parser.add_argument("--reads", type=int, default=2000)
    parser.add_argument("--json", action="store_true")
    parser.add_argument("--rt", action="store_true", help="the real-time loop, 4 boards")
    parser.add_argument("--before", metavar="REF", help="--rt against git REF, interleaved")
    parser.add_argument(
        "--idle",
        metavar="STRATEGY",
        help=f"how every process waits (sets {IDLE_VARIABLE}: block, spin, adaptive[:US])",
    )
    args = parser.parse_args()
    if args.idle is not None:
        try:
            parse_idle(args.idle)
        except ValueError as error:
            print(f"raw1394_read bench: --idle: {error}", file=sys.stderr)
            return 2
        os.environ[IDLE_VARIABLE] = args.idle
    if args.before:
        return compare(args.before, args.rounds, args.reads)
    if shutil.which("gcc") is None:
        print("raw1394_read bench: gcc is needed", file=sys.stderr)
        return 2
    work = Path(tempfile.mkdtemp(prefix="fwbench"))
    os.environ["XDG_RUNTIME_DIR"] = str(work)
    program = work / "loop"
    (work / "loop.c").write_text(RT_PROGRAM if args.rt else PROGRAM)
    subprocess.run(
        ["gcc", "-O2", "-o", str(program), str(work / "loop.c"), "-lraw1394"], check=True
    )
    config = BusConfig(f"bench-raw1394-{os.getpid()}")
    boards = 4 if args.rt else 1
    bus = LaunchedBus(
        config, boards, board="memory", root=work / "fw1394", node_arguments=("--adapter",)
    )
    rows = []
    #: Per real-time round: CPU microseconds per transaction of the adapter, of all
    #: nodes, of the program.
    cpu_us: list[tuple[float, float, float]] = []
    #: Per real-time round: the adapter's user CPU microseconds per transaction.
    adapter_user_us: list[float] = []
    try:
        with bus:
            bus.wait_members()
            if wait_adapter(config, bus.directory, 30.0) is None:
                print("raw1394_read bench: the adapter did not come up", file=sys.stderr)
                return 1
            env = environment(config.name, work / "fw1394")
            adapter = adapter_pid(bus.directory)
            nodes = [record.pid for record in bus.records()]
            if args.rt:
                for _ in range(args.rounds):
                    cycles = args.reads // 4
                    spent = cpu_seconds(adapter), sum(map(cpu_seconds, nodes))
                    user_before = cpu_seconds(adapter, user_only=True)
                    children = resource.getrusage(resource.RUSAGE_CHILDREN)
                    out = subprocess.run(
                        [str(program), str(cycles), str(boards)],
                        env=env,
                        capture_output=True,
                        text=True,
                        check=True,
                    )
                    waited = resource.getrusage(resource.RUSAGE_CHILDREN)
                    program_cpu = waited.ru_utime - children.ru_utime
                    program_cpu += waited.ru_stime - children.ru_stime
                    transactions = 2 * boards * cycles
                    cpu_us.append(
                        (
                            1e6 * (cpu_seconds(adapter) - spent[0]) / transactions,
                            1e6 * (sum(map(cpu_seconds, nodes)) - spent[1]) / transactions,
                            1e6 * program_cpu / transactions,
                        )
                    )
                    adapter_user_us.append(
                        1e6 * (cpu_seconds(adapter, user_only=True) - user_before) / transactions
                    )
                    rows.append((0.0, 0.0, float(out.stdout)))
            with AdapterPort(config.name, root=work / "fw1394") as port:
                port.members()
                for _ in range(0 if args.rt else args.rounds):
                    python_ns = adapter_port_round(port, args.reads)
                    library_ns = library_round(program, env, args.reads)
                    rows.append((python_ns, library_ns, library_ns / python_ns))
    finally:
        shutil.rmtree(work, ignore_errors=True)
    if args.rt:
        rates = [r for _, _, r in rows]
        if args.json:
            report: dict[str, object] = {
                "boards": boards,
                "cycles_per_second": rates,
                "goal": 1000,
                "idle": str(default_idle()),
                "adapter_cpu_us_per_transaction": [a for a, _, _ in cpu_us],
                "node_cpu_us_per_transaction": [n for _, n, _ in cpu_us],
                "program_cpu_us_per_transaction": [p for _, _, p in cpu_us],
                "adapter_user_cpu_us_per_transaction": adapter_user_us,
            }
            print(json.dumps(report))
        else:
            print("real-time loop through libraw1394: per cycle one 64-byte block read and one")
            print(f"16-byte block write to each of {boards} boards (shared machine)")
            print(f"waiting: {IDLE_VARIABLE}={default_idle()}, load {os.getloadavg()[0]:.1f}")
            print("cycles/s per round: " + ", ".join(f"{r:.0f}" for r in rates))
            print(f"median: {statistics.median(rates):.0f} cycles/s (goal >= 1000)")
            adapter_us = statistics.median(a for a, _, _ in cpu_us)
            node_us = statistics.median(n for _, n, _ in cpu_us)
            program_us = statistics.median(p for _, _, p in cpu_us)
            print(
                f"CPU per transaction: adapter {adapter_us:.0f} us (user "
                f"{statistics.median(adapter_user_us):.0f}), nodes {node_us:.0f} us, "
                f"program {program_us:.0f} us"
            )
        return 0
    ratios = [r for _, _, r in rows]
    summary = {
        "reads_per_round": args.reads,
        "rounds": [
            {"adapter_port_us": p / 1e3, "raw1394_read_us": lib / 1e3, "ratio": r}
            for p, lib, r in rows
        ],
        "median_ratio": statistics.median(ratios),
        "goal": 1.3,
    }
    if args.json:
        print(json.dumps(summary))
        return 0
    print("quadlet read of one memory board, per read (interleaved rounds; shared machine)")
    print(f"{'round':>5}  {'AdapterPort':>12}  {'raw1394_read':>12}  {'ratio':>6}")
    for i, (p, lib, r) in enumerate(rows):
        print(f"{i:>5}  {p / 1e3:>10.1f}us  {lib / 1e3:>10.1f}us  {r:>6.2f}")
    print(f"median ratio raw1394_read / AdapterPort: {summary['median_ratio']:.2f} (goal <= 1.3)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
