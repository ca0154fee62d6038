"""A node's turn in one process: the general turn against the one-pass turn.

A real :class:`~fw1394.transport.station.Station` and
:class:`~fw1394.transport.link.ResponderLink` serve a memory space, as a node
process does, with the station's medium replaced by one that hands out the same
request frame on every receive and keeps only a count of the frames sent: what
is timed is the node's own work per request, from the datagram's bytes to the
ack frame's (the socket calls, which both turns make alike, are left out).
Quadlet reads, quadlet writes and 512-quadlet block reads, on an insecure and a
keyed bus; the general turn (``LinkLayer.turn``) and the one-pass turn
(``node_express.node_turn``) are timed in interleaved rounds (A B A B ...), and
Python function calls per request are counted with cProfile.

    python bench/node_turn.py [--rounds 10] [--requests 20000]
"""

from __future__ import annotations

import argparse
import cProfile
import itertools
import pstats
import statistics
import time
from collections.abc import Callable, Iterator
from typing import Any
from unittest import mock

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import THESIS_FPGA, Responder
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
)
from fw1394.packets.fast import encode_packet
from fw1394.transport import station as station_module
from fw1394.transport.link import ResponderLink
from fw1394.transport.media.idle import BLOCK, IdleStrategy
from fw1394.transport.node_express import node_turn
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.sansio.seal import Sealer
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, MemberInfo, pack_table
from fw1394.transport.station import Station
from fw1394.transport.supervision.bus_key import new_key

HOST = MemberInfo(member_id=0x0505, rank=9, contender=True, host=True)
#: No lease, heartbeat or self-ID timeout runs out while a node serves requests
#: from a host that never sends a heartbeat: the bus stays in one generation.
QUIET = Timing(heartbeat=3600.0, lease=1e9, self_id_timeout=1e9)
ROUTE: dict[str, Any] = {"destination_id": 0xFFC0, "tlabel": 5, "source_id": 0xFFC1, "offset": 0x40}
REQUESTS: dict[str, AsyncPacket] = {
    "quadlet read": QuadletReadRequest(**ROUTE),
    "quadlet write": QuadletWriteRequest(**ROUTE, quadlet_data=0x1234),
    "512-quadlet block read": BlockReadRequest(**ROUTE, data_length=2048),
}


class RepeatingMedium:
    """A medium whose every receive is the next of ``frames``; sent frames counted."""

    def __init__(self, config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK):
        self.frames: Iterator[bytes] = iter(())
        self.sent = 0

    def receive(self) -> bytes | None:
        return next(self.frames)

    def receive_queued(self) -> bytes | None:
        return None

    def send(self, frame: bytes) -> None:
        self.sent += 1

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        pass

    def close(self) -> None:
        pass


class Node:
    """A node (physical ID 0) in generation 1 that the host sends ``request``."""

    def __init__(self, request: AsyncPacket, keyed: bool) -> None:
        key = new_key() if keyed else b""
        self.config = BusConfig(f"bench-turn{int(keyed)}", key=key)
        with mock.patch.object(station_module, "open_medium", RepeatingMedium):
            self.station = Station(self.config, rank=1, drop_acks=True, timing=QUIET)
        medium = self.station.medium
        assert isinstance(medium, RepeatingMedium)
        self.medium = medium
        self.seal = Sealer(key).seal if keyed else bytes
        self.request = encode_packet(request)
        self.sequence = itertools.count(1)
        self.keyed = keyed
        responder = Responder(0xFFFF, MemorySpace(4096), THESIS_FPGA)
        self.link = ResponderLink(
            responder, self.station.send, self.station, epoch=time.monotonic()
        )
        medium.frames = iter(
            [self.frame(FrameKind.bus_reset, pack_table((self.station.info, HOST)))]
        )
        self.link.turn()
        assert self.station.membership.phy_id == 0

    def frame(self, kind: int, payload: bytes) -> bytes:
        sequence = next(self.sequence)
        header = FrameHeader(kind, self.config.tag, HOST.member_id, 1, 1, 0xFF, 2, sequence)
        return self.seal(header.pack() + payload)

    def load(self, count: int) -> None:
        """The next ``count`` receives: the request (on a keyed bus each sealed afresh,
        as a copy would be dropped as a replay), made before the clock starts."""
        if self.keyed:
            frames = [self.frame(FrameKind.async_packet, self.request) for _ in range(count)]
            self.medium.frames = iter(frames)
        else:
            self.medium.frames = itertools.repeat(self.frame(FrameKind.async_packet, self.request))


def per_request(node: Node, turn: Callable[[], float], count: int) -> float:
    node.load(count)
    start = time.perf_counter()
    for _ in range(count):
        turn()
    return (time.perf_counter() - start) / count


def calls_per_request(node: Node, turn: Callable[[], float], count: int = 1000) -> float:
    node.load(count)
    profile = cProfile.Profile()
    profile.enable()
    for _ in range(count):
        turn()
    profile.disable()
    stats = pstats.Stats(profile).stats  # type: ignore[attr-defined]
    calls = sum(entry[1] for entry in stats.values()) - 1  # not profile.disable()
    return float(calls / count)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=10, help="A B rounds (default 10)")
    parser.add_argument("--requests", type=int, default=20000, help="requests per round")
    args = parser.parse_args()
    rounds, count = max(1, args.rounds), max(1, args.requests)
    print(f"{'request':23} {'bus':8} {'general us':>10} {'one-pass us':>11} {'ratio':>13} calls")
    for (name, request), keyed in itertools.product(REQUESTS.items(), (False, True)):
        general, express = Node(request, keyed), Node(request, keyed)
        turns = {"general": general.link.turn, "one-pass": node_turn(express.link)}
        nodes = {"general": general, "one-pass": express}
        assert turns["one-pass"] != express.link.turn
        try:
            for path, turn in turns.items():
                per_request(nodes[path], turn, count // 10)  # warm-up
            times: dict[str, list[float]] = {path: [] for path in turns}
            for _ in range(rounds):
                for path, turn in turns.items():
                    times[path].append(per_request(nodes[path], turn, count))
            ratios = [e / g for g, e in zip(times["general"], times["one-pass"], strict=True)]
            calls = [round(calls_per_request(nodes[path], turn)) for path, turn in turns.items()]
            for node in nodes.values():  # every request was answered
                assert node.medium.sent > rounds * count
        finally:
            general.station.close()
            express.station.close()
        print(
            f"{name:23} {'keyed' if keyed else 'insecure':8} "
            f"{statistics.median(times['general']) * 1e6:10.2f} "
            f"{statistics.median(times['one-pass']) * 1e6:11.2f} "
            f"{min(ratios):5.2f}..{max(ratios):<5.2f} {calls[0]} -> {calls[1]}"
        )
    print(
        "\nus per request (median of the rounds); ratio: one-pass / general, range over "
        "\nthe interleaved rounds; calls: Python and C function calls per request."
    )


if __name__ == "__main__":
    main()
