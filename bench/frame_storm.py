"""Arbitrary frames at a live bus: does any member die, does any later transaction go wrong?

    python bench/frame_storm.py                    # 100,000 frames at each kind of bus
    python bench/frame_storm.py --frames 5000      # a shorter run
    python bench/frame_storm.py --json             # one JSON object per bus

Three memory nodes (separate processes) and this host join a bus, once
``--insecure`` and once keyed (the frames sealed with the key, as a member with
a bug would send them, so that they reach the parsers behind the MAC check). A
thrower sends frames drawn by :func:`fw1394.fuzz.bus_frames.hostile_frame`, in
bursts, while the host keeps serving the bus; every ``--check-every`` frames it
checks that every node process is still the one started. Afterwards the bus
must settle to its real members and each node must hold exactly the value
written to it, found by board ID. Printed per bus: frames, member deaths, what
the host dropped as malformed, forged and replayed, and whether the
transactions after the storm were right.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import random
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

from fw1394.fuzz.bus_frames import hostile_frame
from fw1394.host.bus_port import BusPort
from fw1394.transport.bus_host import BusError, TransactionError
from fw1394.transport.media.choice import BusMedium, open_medium
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.sansio.seal import Sealer
from fw1394.transport.sansio.wire import DESTINATION_OFFSET
from fw1394.transport.supervision.bus_key import new_key
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.procs import process_alive

ARGS = ("--heartbeat", "0.05", "--lease", "0.5")
TIMING = Timing(heartbeat=0.05, lease=0.5)
OFFSET = 0x40


def throw(medium: BusMedium, frame: bytes) -> None:
    if not isinstance(medium, Medium):
        medium.send(frame)  # one ring: every member's link looks at every frame
        return
    has_destination = len(frame) > DESTINATION_OFFSET
    where = medium.destinations[frame[DESTINATION_OFFSET]] if has_destination else None
    with contextlib.suppress(BlockingIOError):  # a full queue: lost, as on a wire
        medium.sock.sendto(frame, where or medium.destination)


def settled(port: BusPort, pids: set[int], seconds: float) -> dict[int, int] | None:
    limit = time.monotonic() + seconds
    while time.monotonic() < limit:
        port.poll(0.05)
        members = port.members
        nodes = {m.pid for m in members if not m.host}
        if port.station.membership.ready and nodes == pids and len(members) == len(pids) + 1:
            return {m.board_id: phy for phy, m in enumerate(members) if not m.host}
    return None


def transactions_right(port: BusPort, pids: set[int], seconds: float = 30.0) -> bool:
    limit = time.monotonic() + seconds
    while time.monotonic() < limit:
        try:
            boards = settled(port, pids, limit - time.monotonic())
            if boards is None:
                return False
            values = {board: 0x5A000000 | board << 8 | phy for board, phy in boards.items()}
            for board, phy in boards.items():
                port.write_quadlet(phy, OFFSET, values[board])
            read = {board: port.read_quadlet(phy, OFFSET) for board, phy in boards.items()}
            if boards == settled(port, pids, 5.0):
                return read == values
        except (TransactionError, BusError):
            continue  # a reset the storm left in flight; retried once the bus settles
    return False


def run(keyed: bool, frames: int, nodes: int, check_every: int, seed: int) -> dict[str, Any]:
    rng = random.Random(seed)
    config = BusConfig(f"storm{'k' if keyed else 'i'}{seed}")
    key = new_key() if keyed else None
    seal = (lambda frame: frame) if key is None else Sealer(key).seal
    with (
        tempfile.TemporaryDirectory() as root,
        LaunchedBus(config, nodes, root=Path(root), node_arguments=ARGS, key=key) as bus,
    ):
        bus.wait_members()
        started = {record.pid for record in bus.records()}
        thrower = open_medium(bus.member_config)
        deaths = 0
        began = time.monotonic()
        try:
            with BusPort(bus.member_config, timing=TIMING) as port:
                before = transactions_right(port, started)
                for number in range(frames):
                    throw(thrower, seal(hostile_frame(rng, config.tag, port.generation)))
                    if number % 20 == 19:
                        port.poll(0.001)
                    if number % check_every == check_every - 1:
                        deaths = sum(not process_alive(pid) for pid in started)
                        if deaths:
                            break
                storm_seconds = time.monotonic() - began
                deaths = sum(not process_alive(pid) for pid in started)
                after = transactions_right(port, started)
                restarted = {record.pid for record in bus.records()} != started
                drops = port.station.drops
        finally:
            thrower.close()
    return {
        "bus": "keyed" if keyed else "insecure",
        "frames": frames,
        "nodes": nodes,
        "seconds": round(storm_seconds, 1),
        "member_deaths": deaths + (1 if restarted and not deaths else 0),
        "right_before": before,
        "right_after": after,
        "host_dropped": {
            "malformed": drops.malformed,
            "forged": drops.forged,
            "replayed": drops.replayed,
        },
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=100_000)
    parser.add_argument("--nodes", type=int, default=3)
    parser.add_argument("--check-every", type=int, default=1000)
    parser.add_argument("--seed", type=int, default=1394)
    parser.add_argument("--json", action="store_true")
    args = parser.parse_args()
    failed = False
    for keyed in (False, True):
        result = run(keyed, args.frames, args.nodes, args.check_every, args.seed)
        failed |= bool(result["member_deaths"]) or not result["right_after"]
        if args.json:
            print(json.dumps(result))
        else:
            dropped = result["host_dropped"]
            print(
                f"{result['bus']:8}  {result['frames']:,} frames in {result['seconds']} s, "
                f"{result['member_deaths']} member deaths, transactions after: "
                f"{'right' if result['right_after'] else 'WRONG'}; the host dropped "
                f"{dropped['malformed']} malformed, {dropped['forged']} forged, "
                f"{dropped['replayed']} replayed"
            )
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
