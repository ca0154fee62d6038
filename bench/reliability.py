"""Reads on a faulty virtual bus: does any read come back with another address's data?

    python bench/reliability.py                   # 20,000 reads per mode, 60 outstanding
    python bench/reliability.py --reads 2000      # a shorter run
    python bench/reliability.py --json            # one JSON object instead of the report

A memory node and this host join a bus on which every member loses, duplicates
and delays a share of its asynchronous frames (5 % each by default). The host
fills the node's 16,384 quadlets with values that differ for every address,
then keeps ``--outstanding`` quadlet reads of distinct, random addresses in
flight, and checks each completed read against the value of its own address.

Two modes run interleaved, in chunks, on the same bus and host:

* ``held``: the engine's default; a label stays out of use for the split
  timeout after its transaction got its answer (a copy of the answer may still
  come), twice that after it ended without one.
* ``answered-free``: ``duplicate_window=0``; a label that got its answer is free
  at once (only unanswered ends hold it), which is what the engine did for
  every end before labels were held.

Printed per mode: reads, wrong data, hangs (a read with no end at all), failures
by reason, reads per second, and the held mode's rate as a ratio of the other's.
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import tempfile
import time
from collections import Counter, deque
from pathlib import Path
from typing import Any

from fw1394.engine import ReadCompleted, TransactionFailed, WriteCompleted
from fw1394.engine.faults import FaultConfig
from fw1394.transport.bus_host import MAX_BLOCK_WRITE, BusHost
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.launch import LaunchedBus

QUADLETS = 65536 // 4  # the memory board's size
TIMING = Timing(heartbeat=0.1, lease=2.0)
MODES = ("held", "answered-free")


def value_at(quadlet: int) -> int:
    """A different 32-bit value for every quadlet (an odd multiplier is a bijection)."""
    return (quadlet * 0x9E3779B1 + 0x01234567) & 0xFFFFFFFF


def fill(host: BusHost, node: int) -> None:
    """Write every quadlet's value, again until the write is known to have landed."""
    step = MAX_BLOCK_WRITE // 4
    for first in range(0, QUADLETS, step):
        count = min(step, QUADLETS - first)
        data = b"".join(value_at(q).to_bytes(4, "big") for q in range(first, first + count))
        landed = False
        while not landed:  # writes of the same data are idempotent
            landed = isinstance(
                host.wait(host.start_write_block(node, 4 * first, data)), WriteCompleted
            )


def measure(
    host: BusHost, node: int, reads: int, outstanding: int, rng: random.Random
) -> dict[str, Any]:
    """``reads`` quadlet reads, ``outstanding`` in flight, distinct addresses among them."""
    counts: Counter[str] = Counter()
    wrong: list[tuple[int, int]] = []
    in_flight: deque[tuple[int, int]] = deque()
    busy: set[int] = set()
    started = 0
    begin = time.monotonic()
    while started < reads or in_flight:
        while started < reads and len(in_flight) < outstanding:
            quadlet = rng.randrange(QUADLETS)
            if quadlet in busy:
                continue
            busy.add(quadlet)
            in_flight.append((host.start_read_quadlet(node, 4 * quadlet), quadlet))
            started += 1
        tid, quadlet = in_flight.popleft()
        busy.discard(quadlet)
        event = host.wait(tid)
        if isinstance(event, ReadCompleted):
            got = int.from_bytes(event.data, "big")
            if got == value_at(quadlet):
                counts["ok"] += 1
            else:
                counts["wrong_data"] += 1
                wrong.append((quadlet, got))
        elif isinstance(event, TransactionFailed) and event.detail == "no end":
            counts["hang"] += 1
        elif isinstance(event, TransactionFailed):
            counts[str(event.reason)] += 1
    seconds = time.monotonic() - begin
    return {"counts": dict(counts), "seconds": seconds, "wrong_examples": wrong[:5]}


def run(args: argparse.Namespace) -> dict[str, Any]:
    faults = (args.loss, args.duplicate, args.delay)
    node_arguments = (
        *("--heartbeat", str(TIMING.heartbeat), "--lease", str(TIMING.lease)),
        *("--loss", str(args.loss), "--duplicate", str(args.duplicate)),
        *("--delay", str(args.delay), "--delay-time", str(args.delay_time)),
        *("--fault-seed", str(args.seed)),
    )
    config = BusConfig(f"reliability{int(time.time() * 1000) % 10**9}")
    rng = random.Random(args.seed)
    totals: dict[str, dict[str, Any]] = {
        mode: {"counts": Counter(), "seconds": 0.0, "wrong_examples": []} for mode in MODES
    }
    host_faults = FaultConfig(*faults, delay_seconds=args.delay_time, seed=args.seed + 1)
    with (
        tempfile.TemporaryDirectory() as root,
        LaunchedBus(config, 1, root=Path(root), node_arguments=node_arguments) as bus,
    ):
        bus.wait_members()
        with BusHost(
            config,
            timing=TIMING,
            faults=host_faults,
            ack_timeout=args.ack_timeout,
            split_timeout=args.split_timeout,
        ) as host:
            ((node, _),) = host.nodes()
            fill(host, node)
            done = 0
            while done < args.reads:
                chunk = min(args.chunk, args.reads - done)
                for mode in MODES:
                    host.requester.duplicate_window = None if mode == "held" else 0.0
                    result = measure(host, node, chunk, args.outstanding, rng)
                    total = totals[mode]
                    total["counts"].update(result["counts"])
                    total["seconds"] += result["seconds"]
                    total["wrong_examples"] += result["wrong_examples"]
                done += chunk
    for total in totals.values():
        total["counts"] = dict(total["counts"])
        total["reads_per_second"] = round(args.reads / total["seconds"], 1)
        total["seconds"] = round(total["seconds"], 1)
        total["wrong_examples"] = total["wrong_examples"][:5]
    ratio = totals["held"]["reads_per_second"] / totals["answered-free"]["reads_per_second"]
    return {
        "reads_per_mode": args.reads,
        "outstanding": args.outstanding,
        "loss": args.loss,
        "duplicate": args.duplicate,
        "delay": args.delay,
        "delay_time": args.delay_time,
        "ack_timeout": args.ack_timeout,
        "split_timeout": args.split_timeout,
        "modes": totals,
        "held_rate_over_answered_free": round(ratio, 3),
    }


def report(results: dict[str, Any]) -> None:
    print(
        f"{results['reads_per_mode']} quadlet reads per mode, "
        f"{results['outstanding']} outstanding, "
        f"loss {results['loss']}, duplicate {results['duplicate']}, delay {results['delay']} "
        f"({results['delay_time'] * 1000:g} ms); ack timeout {results['ack_timeout']} s, "
        f"split timeout {results['split_timeout']} s"
    )
    print(f"{'mode':<14} {'ok':>7} {'wrong':>6} {'hang':>5} {'reads/s':>8}  failures")
    for mode, total in results["modes"].items():
        counts = dict(total["counts"])
        ok, wrong, hang = (counts.pop(k, 0) for k in ("ok", "wrong_data", "hang"))
        failures = ", ".join(f"{k} {v}" for k, v in sorted(counts.items())) or "none"
        print(f"{mode:<14} {ok:>7} {wrong:>6} {hang:>5} {total['reads_per_second']:>8}  {failures}")
        for quadlet, got in total["wrong_examples"]:
            print(f"    quadlet {quadlet} read {got:#010x}, holds {value_at(quadlet):#010x}")
    print(f"held / answered-free reads per second: {results['held_rate_over_answered_free']}")


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--reads", type=int, default=20000, help="reads per mode")
    parser.add_argument("--outstanding", type=int, default=60, help="reads in flight (1-64)")
    parser.add_argument("--chunk", type=int, default=2000, help="reads per mode before switching")
    parser.add_argument("--loss", type=float, default=0.05)
    parser.add_argument("--duplicate", type=float, default=0.05)
    parser.add_argument("--delay", type=float, default=0.05)
    parser.add_argument("--delay-time", type=float, default=0.002, help="seconds")
    parser.add_argument("--ack-timeout", type=float, default=0.1, help="seconds")
    parser.add_argument("--split-timeout", type=float, default=0.1, help="seconds")
    parser.add_argument("--seed", type=int, default=1)
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args()
    if not 1 <= args.outstanding <= 64 or args.reads < 1 or args.chunk < 1:
        print("--outstanding must be 1-64, --reads and --chunk positive", file=sys.stderr)
        return 2
    results = run(args)
    if args.json:
        print(json.dumps(results))
    else:
        report(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
