"""The JHU real-time loop against ``fw1394 jhu serve``: rates, CPU per cycle and the goals.

What runs: for each firmware, board count and side, a fresh ``fw1394 jhu serve``
(boards 0..N-1) and ``fw1394 jhu rt --protocol broadcast-read-write --json``,
fw1394's own client doing the JHU host library's cycle against it (the real
library is not in the repository). A cycle is the library's ReadAllBoards and
WriteAllBoards with broadcast: a flush of the host socket, the broadcast query
(a quadlet write of ``sequence << 16 | board mask`` to 0x1800), then the hub's
data (Ethernet-only, firmware 9 on: the hub's unasked block read response;
bridge mode, firmware 8 and before: a block read of hub memory at 0x1000 from
the hub), then one broadcast block write carrying every board's write block.
The commands are the same every cycle (every DAC valid at midrange, control
word 0): an idle controller, not a moving one. The server waits for datagrams
blocked in the kernel (epoll), never busy-waiting, so each datagram pays the
scheduler's wake-up.

Printed per run: the loop's rate beside raw UDP ping-pongs to the same server,
interleaved in the same run (the floor the loop cannot beat right now), the
CPU time per cycle of the client (its process time) and of the server (from
/proc, with the ping-pongs it answered during the run taken off: they are timed
alone, as many again, after the run; the scan's few ms stay in), the server's
CPU per ping-pong, and the load average. The
machine may be shared: CPU per cycle and the interleaved ratios are the
figures to judge a change by; the Hz goals hold on a quiet machine.

``--before REF`` also runs the checkout of a git ref (a temporary worktree) as
the baseline, interleaved with this checkout: with ``--rounds N`` each
firmware and board count is run N times on each side, ABAB (alternating which
side goes first), so both sides see the same minutes of a shared machine; the
summary gives each side's range of rates and CPU per cycle, the per-round
ratios, and a row per loop-rate goal with its verdict (median of the rounds).

Firmware 9 (Ethernet-only, multicast) needs a network namespace whose multicast
route is on lo: run as root and this script makes one per run (``unshare -n``);
otherwise only firmware 8 and before (bridge mode) run, on an unprivileged port.

    sudo python bench/jhu_rt.py --boards 4 8 --firmware 8 9 --rounds 4 --before main
    sudo python bench/jhu_rt.py --boards 1 4 8 --cycles 2000
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
    if int(firmware) >= 9:
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
    # The loop's run also had the server answer one ping-pong per cycle (a quadlet read
    # of the hub's hardware version, as jhu rt sends it): timed alone here, then taken off.
    import select, socket
    from fw1394.boards.qla1.regs import BoardRegister
    from fw1394.packets import QuadletReadRequest
    from fw1394.packets.eth1394_fast import request_datagram
    from fw1394.packets.fast import encode_packet
    read = QuadletReadRequest(destination_id=0xFFC0, tlabel=0, source_id=0xFFD0,
                              offset=BoardRegister.HARDWARE_VERSION)
    ping = request_datagram(int(firmware) >= 9, 0, encode_packet(read))
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        pinged = cpu(server.pid)
        for _ in range(int(cycles)):
            sock.sendto(ping, ("127.0.0.1", int(port)))
            if not select.select([sock], [], [], 0.2)[0]:
                sys.exit("the server did not answer a ping-pong")
            sock.recv(65535)
        per_ping = (cpu(server.pid) - pinged) / int(cycles)
    stop(server)
    report = json.loads(host.stdout)
    # The server also served the scan (a few ms): a small overestimate.
    report["server_cpu_ms_per_cycle"] = 1e3 * ((after - before) / int(cycles) - per_ping)
    report["server_cpu_ms_per_ping"] = 1e3 * per_ping
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


#: The dVRK's loop-rate goals: (bridge mode?, boards) -> Hz. Bridge mode is firmware 8 and
#: before (the hub forwards to the other boards over FireWire), else Ethernet-only.
GOALS = {(True, 4): 2000.0, (True, 8): 1000.0, (False, 4): 2000.0, (False, 8): 3000.0}
MULTICAST_FIRMWARE = 9


def mode(firmware: int) -> str:
    return "bridge" if firmware < MULTICAST_FIRMWARE else "Ethernet-only"


def print_run(side: str, boards: int, r: dict[str, object]) -> None:
    loop, ping = number(r, "loop_hz"), number(r, "ping_pong_hz")
    print(
        f"{side:>6} {boards:>6} {r['firmware']!s:>3} {loop:>8.0f} {ping:>8.0f} "
        f"{loop / ping:>6.2f} {number(r, 'client_cpu_ms_per_cycle'):>9.3f} "
        f"{number(r, 'server_cpu_ms_per_cycle'):>9.3f} "
        f"{number(r, 'server_cpu_ms_per_ping'):>9.3f} {number(r, 'load_1min'):>5.1f}",
        flush=True,
    )


def span(values: list[float], digits: int = 0) -> str:
    return f"{min(values):.{digits}f}-{max(values):.{digits}f}"


Key = tuple[str, int, int]  # side, firmware, boards


def summary(runs: dict[Key, list[dict[str, object]]], before: bool) -> None:
    """Per firmware and board count: each side's ranges, the ratios, then the goal rows."""
    print("\nper firmware and board count, range over rounds (median after/before per round)")
    verdicts = []
    for (side, firmware, boards), reports in runs.items():
        if side != "after":
            continue

        def column(key: str, reports: list[dict[str, object]] = reports) -> list[float]:
            return [number(r, key) for r in reports]

        hz, server, client = (
            column("loop_hz"),
            column("server_cpu_ms_per_cycle"),
            column("client_cpu_ms_per_cycle"),
        )
        line = (
            f"fw {firmware} ({mode(firmware)}), {boards} boards: loop {span(hz)} Hz, "
            f"server {span(server, 3)} ms, client {span(client, 3)} ms per cycle"
        )
        if before:
            old = runs[("before", firmware, boards)]
            pairs = list(zip(reports, old, strict=True))
            for key, label in (
                ("loop_hz", "loop Hz"),
                ("server_cpu_ms_per_cycle", "server CPU"),
                ("client_cpu_ms_per_cycle", "client CPU"),
            ):
                ratios = [number(a, key) / number(b, key) for a, b in pairs]
                line += f"\n    {label} after/before {span(ratios, 2)} "
                line += f"(median {statistics.median(ratios):.2f})"
            line += (
                f"; before: loop {span([number(r, 'loop_hz') for r in old])} Hz, "
                f"server {span([number(r, 'server_cpu_ms_per_cycle') for r in old], 3)} ms"
            )
        print(line)
        goal = GOALS.get((firmware < MULTICAST_FIRMWARE, boards))
        if goal is not None:
            median = statistics.median(hz)
            verdict = "met" if median >= goal else "missed"
            verdicts.append(
                f"goal {mode(firmware)} (fw {firmware}) {boards} boards >= {goal:.0f} Hz: "
                f"median {median:.0f} Hz (load {statistics.median(column('load_1min')):.1f}): "
                f"{verdict}"
            )
    print("\nloop-rate goals (after; judge on a quiet machine)")
    print("\n".join(verdicts) or "no goal row among these firmware and board counts")


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
        nargs="+",
        default=None,
        help="firmware revisions (default 8 and 9 when run as root, else 8: bridge mode)",
    )
    args = parser.parse_args()
    namespace = os.geteuid() == 0 and shutil.which("unshare") is not None
    firmwares = args.firmware or ([8, 9] if namespace else [8])
    for firmware in firmwares:
        if firmware >= MULTICAST_FIRMWARE and not namespace:
            parser.error(f"--firmware {firmware} multicasts: run as root (a namespace per run)")
    with contextlib.ExitStack() as stack:
        sides = {"after": HERE}
        if args.before:
            sides = {"before": stack.enter_context(checkout(args.before)), "after": HERE}
        print(f"{'side':>6} {'boards':>6} {'fw':>3} {'loop Hz':>8} {'ping Hz':>8} {'ratio':>6} "
              f"{'client ms':>9} {'server ms':>9} {'ping srv':>9} {'load':>5}")  # fmt: skip
        runs: dict[Key, list[dict[str, object]]] = {}
        for round_number in range(args.rounds):
            # ABAB: the side that goes first alternates, so drift hits both alike.
            order = list(sides) if round_number % 2 == 0 else list(reversed(sides))
            for firmware in firmwares:
                for boards in args.boards:
                    for side in order:
                        r = run(sides[side], boards, args.cycles, args.protocol, namespace,
                                firmware)  # fmt: skip
                        print_run(side, boards, r)
                        runs.setdefault((side, firmware, boards), []).append(r)
    summary(runs, bool(args.before))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
