"""Where a quadlet read's time goes, step by step, on the host's side.

A fresh bus of one node (``memory`` unless ``--board`` says otherwise), the
host in this process on the first CPU and the node on the others, every
process waiting by the run's idle strategy (``FW1394_IDLE``). The host's
station and socket are wrapped with clocks, so each read is cut into steps:
the host's work before its request leaves, the Python and the ``sendto`` of
the request, the wait for the answer (the node's whole turn and both
deliveries), judging the answer, the Python and the ``sendto`` of the host's
ack, and the rest of the call. The clocks cost a little; reads without them
are timed in interleaved rounds, so the report says how much.

    python bench/read_steps.py [--board snake2010] [--reads 3000] [--rounds 6] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

from fw1394.boards.registry import BOARDS
from fw1394.experiments.private_bus import PrivateBus
from fw1394.experiments.regime import settle
from fw1394.experiments.timing import collector_paused, cpu_split, pin
from fw1394.host.bus_port import BusPort
from fw1394.transport.media.idle import default_idle
from fw1394.transport.media.udp import Medium

STEPS = (
    ("host: from the call to the request's send", "prepare"),
    ("host: the request's send, Python", "send_python"),
    ("kernel: the request's sendto", "send_kernel"),
    ("the answer: node's turn, both deliveries, host's receive", "wait"),
    ("host: judging the answer", "judge"),
    ("host: the ack's send, Python", "ack_python"),
    ("kernel: the ack's sendto", "ack_kernel"),
    ("host: timers and the return", "finish"),
)


class Clocks:
    """Timestamps (ns) taken at the edges of the host's station and socket calls."""

    def __init__(self, port: BusPort) -> None:
        station = port.station
        medium = station.medium
        if not isinstance(medium, Medium):
            raise SystemExit("read_steps times the UDP medium's sends: unset FW1394_MEDIUM")
        self.marks: list[int] = []
        self._originals = (station.send, station.receive, medium._sendto)
        self._station, self._medium = station, medium
        clock, marks = time.perf_counter_ns, self.marks

        def edges(call: Callable[..., Any]) -> Callable[..., Any]:
            def timed(*args: Any) -> Any:
                marks.append(clock())
                result = call(*args)
                marks.append(clock())
                return result

            return timed

        station.send, station.receive = edges(station.send), edges(station.receive)  # type: ignore[method-assign]
        medium._sendto = edges(medium._sendto)

    def restore(self) -> None:
        send, receive, sendto = self._originals
        self._station.send, self._station.receive = send, receive  # type: ignore[method-assign]
        self._medium._sendto = sendto


def steps_of(start: int, marks: list[int], end: int) -> dict[str, float] | None:
    """One read's steps in µs from its marks, or None unless it went the common way.

    The common way makes exactly: send (sendto inside), receive, send (sendto inside).
    """
    if len(marks) != 10:
        return None
    s1, k1, k1e, s1e, r, re, s2, k2, k2e, s2e = marks
    us = 1e-3
    return {
        "prepare": (s1 - start) * us,
        "send_python": ((s1e - s1) - (k1e - k1)) * us,
        "send_kernel": (k1e - k1) * us,
        "wait": (re - r) * us,
        "judge": (s2 - re) * us,
        "ack_python": ((s2e - s2) - (k2e - k2)) * us,
        "ack_kernel": (k2e - k2) * us,
        "finish": (end - s2e) * us,
    }


def measure(board: str, reads: int, rounds: int) -> dict[str, Any]:
    split = cpu_split()
    if split is not None:
        pin([0], split[0])
    with PrivateBus(board, cpus=None if split is None else split[1]) as bus:
        port = bus.port
        for _ in range(500):
            port.read_quadlet(0, 0)
        plain: list[float] = []
        cut: list[dict[str, float]] = []
        totals: list[float] = []
        skipped = 0
        clock = time.perf_counter_ns
        per_round = max(1, reads // rounds)
        with collector_paused():
            for _ in range(rounds):
                settle()
                for _ in range(per_round):
                    start = clock()
                    port.read_quadlet(0, 0)
                    plain.append((clock() - start) / 1000)
                settle()
                clocks = Clocks(port)
                try:
                    for _ in range(per_round):
                        clocks.marks.clear()
                        start = clock()
                        port.read_quadlet(0, 0)
                        end = clock()
                        steps = steps_of(start, list(clocks.marks), end)
                        if steps is None:
                            skipped += 1
                            continue
                        cut.append(steps)
                        totals.append((end - start) / 1000)
                finally:
                    clocks.restore()
    medians = {key: statistics.median(row[key] for row in cut) for _, key in STEPS}
    return {
        "board": board,
        "idle": str(default_idle()),
        "pinned": split is not None,
        "reads": len(cut),
        "not_the_common_way": skipped,
        "steps_p50_us": {key: round(value, 2) for key, value in medians.items()},
        "sum_of_step_medians_us": round(sum(medians.values()), 2),
        "clocked_read_p50_us": round(statistics.median(totals), 2),
        "plain_read_p50_us": round(statistics.median(plain), 2),
    }


def report(result: dict[str, Any]) -> None:
    print(
        f"quadlet reads of a {result['board']} node, idle {result['idle']}, "
        + ("host and node on separate CPUs" if result["pinned"] else "one CPU")
        + f"; {result['reads']} reads cut into steps (medians, µs):"
    )
    for label, key in STEPS:
        print(f"  {label:<58} {result['steps_p50_us'][key]:6.2f}")
    print(
        f"  {'sum of the step medians':<58} {result['sum_of_step_medians_us']:6.2f}\n"
        f"read p50 with the clocks {result['clocked_read_p50_us']:.2f} µs, without them "
        f"{result['plain_read_p50_us']:.2f} µs (interleaved rounds)"
    )
    if result["not_the_common_way"]:
        print(f"({result['not_the_common_way']} reads took another way and are not cut)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument(
        "--board", default="memory", choices=sorted(BOARDS), help="board kind of the node"
    )
    parser.add_argument("--reads", type=int, default=3000, help="reads with and without clocks")
    parser.add_argument("--rounds", type=int, default=6, help="interleaved rounds (default 6)")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()
    if args.reads < 10 or args.rounds < 1:
        parser.exit(2, "bench/read_steps.py: --reads must be 10 or more, --rounds 1 or more\n")
    result = measure(args.board, args.reads, args.rounds)
    if args.json:
        print(json.dumps(result))
    else:
        report(result)
    return 0


if __name__ == "__main__":
    sys.exit(main())
