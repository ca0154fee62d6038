"""The JHU real-time loop against ``fw1394 jhu serve``: rates beside the machine's floor.

For each board count, a fresh server and ``fw1394 jhu rt --json``: the loop's
rate is printed beside raw UDP ping-pongs to the same server, interleaved in
the same run (the floor the loop cannot beat right now), with the CPU time
per cycle of the client and of the server (from /proc) and the load average,
since the machine may be shared.

``--before REF`` also runs the checkout of a git ref (a temporary worktree) as
the baseline, interleaved with this checkout: with ``--rounds N`` each board
count is run N times on each side, ABAB (alternating which side goes first),
so both sides see the same minutes of a shared machine; the summary gives the
range of each side's rate and of the per-pair ratio.

Firmware 9 (Ethernet-only, multicast) needs a network namespace whose multicast
route is on lo: run as root and this script makes one per run (``unshare -n``);
otherwise it falls back to firmware 8 (bridge mode) on an unprivileged port.
``--firmware 8`` (or any revision before 9) measures bridge mode, in a namespace
of its own too when run as root.

    sudo python bench/jhu_rt.py --boards 1 4 8 --cycles 2000
    sudo python bench/jhu_rt.py --boards 4 8 --rounds 4 --before main
    sudo python bench/jhu_rt.py --boards 4 8 --firmware 8 --rounds 4 --before main
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
import textwrap
from collections.abc import Iterator
from pathlib import Path

from fw1394.cli.dissect import positive

HERE = Path(__file__).resolve().parents[1]

RUN = textwrap.dedent(
    """
    import json, os, subprocess, sys
    root, boards, firmware, port, cycles, protocol = sys.argv[1:7]
    import fw1394
    if not fw1394.__file__.startswith(root):
        sys.exit(f"fw1394 comes from {fw1394.__file__}, not from {root}")
    from fw1394.transport.supervision.stop import stop
    if port == "1394":  # a namespace of its own: loopback starts down
        subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
    if firmware == "9":
        subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    cli = [sys.executable, "-m", "fw1394.cli.main", "jhu"]
    server = subprocess.Popen(cli + ["serve", "--boards", boards, "--firmware", firmware,
                                     "--eth1394", f"127.0.0.1:{port}"],
                              stderr=subprocess.PIPE, text=True)
    server.stderr.readline()

    def cpu(pid):
        fields = open(f"/proc/{pid}/stat").read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")

    args = ["rt", "-p", f"udp:127.0.0.1:{port}", "--json", "--receive-timeout", "0.2",
            "--cycles", cycles]
    if protocol:
        args += ["--protocol", protocol]
    before = cpu(server.pid)
    host = subprocess.run(cli + args, capture_output=True, text=True)
    after = cpu(server.pid)
    stop(server)
    report = json.loads(host.stdout)
    # The server also served the scan (a few ms): a small overestimate.
    report["server_cpu_ms_per_cycle"] = 1e3 * (after - before) / int(cycles)
    report["firmware"] = int(firmware)
    print(json.dumps(report))
    """
)


def run(
    root: Path, boards: int, cycles: int, protocol: str | None, namespace: bool, firmware: int
) -> dict[str, object]:
    """One server and one ``jhu rt`` run of the checkout at ``root``."""
    port = "1394" if namespace else "21394"
    command = [sys.executable, "-c", RUN, str(root), str(boards), str(firmware), port, str(cycles)]
    command.append(protocol or "")
    if namespace:
        command = ["unshare", "-n", *command]
    environment = {**os.environ, "PYTHONPATH": str(root)}
    done = subprocess.run(
        command, capture_output=True, text=True, timeout=600, cwd=root, env=environment
    )
    if done.returncode != 0:
        raise SystemExit(f"run with {boards} boards failed: {done.stderr.strip()}")
    result: dict[str, object] = json.loads(done.stdout.strip().splitlines()[-1])
    return result


@contextlib.contextmanager
def checkout(ref: str) -> Iterator[Path]:
    """A temporary git worktree of ``ref`` (detached), removed afterwards."""
    place = Path(tempfile.mkdtemp(prefix="jhu-rt-before-")) / "tree"
    git = ["git", "-C", str(HERE)]
    made = subprocess.run([*git, "worktree", "add", "--detach", str(place), ref],
                          capture_output=True, text=True)  # fmt: skip
    if made.returncode:
        shutil.rmtree(place.parent, ignore_errors=True)
        last = (made.stderr.strip().splitlines() or ["git worktree add failed"])[-1]
        sys.exit(f"jhu_rt.py: --before {ref}: {last}")
    try:
        yield place
    finally:
        subprocess.run([*git, "worktree", "remove", "--force", str(place)], check=True)
        shutil.rmtree(place.parent, ignore_errors=True)


def number(report: dict[str, object], key: str) -> float:
    value = report[key]
    assert isinstance(value, int | float)
    return float(value)


def print_run(side: str, boards: int, r: dict[str, object]) -> None:
    loop, ping = number(r, "loop_hz"), number(r, "ping_pong_hz")
    print(
        f"{side:>6} {boards:>6} {r['firmware']!s:>3} {loop:>8.0f} {ping:>8.0f} "
        f"{loop / ping:>6.2f} {number(r, 'client_cpu_ms_per_cycle'):>9.3f} "
        f"{number(r, 'server_cpu_ms_per_cycle'):>9.3f} {number(r, 'load_1min'):>5.1f}",
        flush=True,
    )


def span(values: list[float], digits: int = 0) -> str:
    return f"{min(values):.{digits}f}-{max(values):.{digits}f}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--boards", type=positive, nargs="+", default=[1, 4, 8])
    parser.add_argument("--cycles", type=positive, default=2000)
    parser.add_argument("--protocol", default="broadcast-read-write")
    parser.add_argument("--rounds", type=positive, default=1, help="runs per board count and side")
    parser.add_argument("--before", metavar="REF", help="git ref run as the baseline, ABAB")
    parser.add_argument(
        "--firmware",
        type=positive,
        default=None,
        help="firmware revision (default 9 when run as root, else 8: bridge mode)",
    )
    args = parser.parse_args()
    namespace = os.geteuid() == 0 and shutil.which("unshare") is not None
    firmware = args.firmware or (9 if namespace else 8)
    if firmware >= 9 and not namespace:
        parser.error(f"--firmware {firmware} multicasts: run as root (a namespace per run)")
    with contextlib.ExitStack() as stack:
        sides = {"after": HERE}
        if args.before:
            sides = {"before": stack.enter_context(checkout(args.before)), "after": HERE}
        print(f"{'side':>6} {'boards':>6} {'fw':>3} {'loop Hz':>8} {'ping Hz':>8} {'ratio':>6} "
              f"{'client ms':>9} {'server ms':>9} {'load':>5}")  # fmt: skip
        rates: dict[tuple[str, int], list[float]] = {}
        for round_number in range(args.rounds):
            # ABAB: the side that goes first alternates, so drift hits both alike.
            order = list(sides) if round_number % 2 == 0 else list(reversed(sides))
            for boards in args.boards:
                for side in order:
                    r = run(sides[side], boards, args.cycles, args.protocol, namespace, firmware)
                    print_run(side, boards, r)
                    rates.setdefault((side, boards), []).append(number(r, "loop_hz"))
    print("\nloop Hz, range over rounds" + (" (after/before: per round)" if args.before else ""))
    for boards in args.boards:
        after = rates[("after", boards)]
        line = f"{boards:>2} boards: after {span(after)}"
        if args.before:
            before = rates[("before", boards)]
            ratios = [a / b for a, b in zip(after, before, strict=True)]
            line += (
                f", before {span(before)}, after/before {span(ratios, 2)} "
                f"(median {statistics.median(ratios):.2f})"
            )
        print(line)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
