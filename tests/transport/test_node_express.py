"""A node's one-pass turn serves every frame as the general turn does.

Two nodes run in lock step, each a real :class:`Station` (its medium replaced by
a script) with a :class:`ResponderLink`: one turns the general way
(:meth:`LinkLayer.turn`), one by :func:`node_turn`. Both are handed the same
frames at the same (fake) clock readings: requests of every kind, sound and
damaged, to this node and to others, answered at once, refused by the memory or
too large for a datagram; requests of the last generation; bus resets that
renumber the node or leave it out; PHY packets, acks, line noise, quiet polls,
forged and replayed frames on a keyed bus; busy acks injected; and the clock
moved past heartbeats, leases and self-ID timeouts between frames. After every
step both must have sent the same datagrams and hold the same station, link and
responder state; and a clean request must never reach the general path.
"""

from __future__ import annotations

import secrets
import tempfile
import time
from collections import deque
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Responder
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.faults import FaultConfig
from fw1394.engine.policy import POLICIES
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    Speed,
)
from fw1394.packets.fast import encode_packet
from fw1394.transport import link as link_module
from fw1394.transport import node_express
from fw1394.transport import station as station_module
from fw1394.transport.link import ResponderLink
from fw1394.transport.media.idle import BLOCK, IdleStrategy
from fw1394.transport.node_express import node_turn
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.seal import Sealer
from fw1394.transport.sansio.wire import (
    AckPayload,
    FrameHeader,
    FrameKind,
    MemberInfo,
    ack_byte,
    pack_table,
)
from fw1394.transport.station import Station
from fw1394.transport.supervision.bus_key import new_key

#: Room for a block read whose answer no datagram carries.
MEMORY = 1 << 16
TOO_LARGE = 65_480
HOST = MemberInfo(member_id=0x0505, rank=9, contender=True, host=True)
OTHER = MemberInfo(member_id=0x0606, rank=5)
NODE_ID = 0x0707
KEY = new_key()


class ScriptedMedium:
    """The medium a station makes, with frames from a script and sent ones kept."""

    def __init__(self, config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK):
        self.inbox: deque[bytes | None] = deque()
        self.sent: list[bytes] = []
        self.filters: list[tuple[int, int | None, bool]] = []

    def receive(self) -> bytes | None:
        return self.inbox.popleft()

    def receive_queued(self) -> bytes | None:
        return None

    def send(self, frame: bytes) -> None:
        self.sent.append(frame)

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        self.filters.append((member_id, phy_id, drop_acks))

    def close(self) -> None:
        pass


class Clock:
    def __init__(self) -> None:
        self.now = 1000.0

    def __call__(self) -> float:
        return self.now


@dataclass
class Node:
    station: Station
    medium: ScriptedMedium
    link: ResponderLink
    space: MemorySpace


@contextmanager
def nodes(
    policy: str = "thesis",
    keyed: bool = False,
    defects: frozenset[str] = frozenset(),
    faults: FaultConfig | None = None,
) -> Iterator[tuple[Clock, Node, Node]]:
    """Two equal nodes, with the station's medium, member id and clock scripted."""
    clock = Clock()
    config = BusConfig("express-node", key=KEY if keyed else b"")
    with pytest.MonkeyPatch.context() as patch, tempfile.TemporaryDirectory() as runtime:
        patch.setenv("XDG_RUNTIME_DIR", runtime)
        patch.setattr(station_module, "open_medium", ScriptedMedium)
        patch.setattr(secrets, "randbits", lambda bits: NODE_ID)
        patch.setattr(time, "monotonic", clock)
        patch.setattr(link_module, "_clock", clock)
        patch.setattr(node_express, "_clock", clock)
        made = []
        for _ in range(2):
            station = Station(config, rank=3, drop_acks=True, faults=faults)
            space = MemorySpace(MEMORY)
            responder = (
                DefectiveResponder(0xFFFF, space, POLICIES[policy], defects=defects)
                if defects
                else Responder(0xFFFF, space, POLICIES[policy])
            )
            link = ResponderLink(responder, station.send, station, epoch=clock.now - 5.0)
            assert isinstance(station.medium, ScriptedMedium)
            made.append(Node(station, station.medium, link, space))
        try:
            yield clock, made[0], made[1]
        finally:
            for node in made:
                node.station.close()


def state(node: Node) -> tuple[Any, ...]:
    station, link = node.station, node.link
    membership, responder = station.membership, link.responder
    return (
        node.medium.sent,
        node.medium.filters,
        node.medium.inbox,
        membership.generation,
        membership.phy_id,
        membership.role,
        membership.members,
        membership.self_ids,
        membership.next_deadline(),
        station.wake_by,
        station.dropped,
        link.due,
        responder.node_id,
        responder.generation,
        responder._ticks,
        responder._busy_left,
        node.space.contents(),
    )


# -- the script ---------------------------------------------------------------------------
@dataclass(frozen=True)
class Request:
    kind: str  # qr, br, qw, bw, lock
    offset: int
    length: int = 4
    label: int = 0
    #: "" a sound request to this node; "damaged", "elsewhere", "broadcast",
    #: "other_bus", "stale" (of the last generation), "short" (a cut-off header).
    spoil: str = ""
    busy: int = 0


@dataclass(frozen=True)
class Reset:
    order: tuple[str, ...]  # the new member table: "node", "host", "other"


@dataclass(frozen=True)
class Frame:
    what: str  # quiet, phy, ack, noise, forged, replay


Step = tuple[float, Request | Reset | Frame]

requests = st.builds(
    Request,
    kind=st.sampled_from(["qr", "br", "qw", "bw", "lock"]),
    offset=st.sampled_from([0, 8, 0x40, MEMORY - 4, MEMORY, 2, 0xFFFF_F000_0400]),
    length=st.sampled_from([0, 4, 6, 64, 2048, 65_000, TOO_LARGE]),
    label=st.integers(0, 63),
    spoil=st.sampled_from(
        ["", "", "", "", "", "damaged", "elsewhere", "broadcast", "other_bus", "stale", "short"]
    ),
    busy=st.sampled_from([0, 0, 0, 1]),
)
resets = st.builds(
    Reset,
    st.permutations(["node", "host", "other"]).map(tuple)
    | st.sampled_from([("host", "other"), ("host",), ("host", "node")]),
)
frames = st.builds(Frame, st.sampled_from(["quiet", "phy", "ack", "noise", "forged", "replay"]))
advances = st.sampled_from([0.0, 0.0, 0.0001, 0.02, 0.15, 1.2])
steps = st.tuples(advances, st.one_of(requests, requests, resets, frames))


class Bus:
    """What the rest of the bus sends the node: its frames, sealed on a keyed bus."""

    def __init__(self, keyed: bool) -> None:
        self.tag = BusConfig("express-node").tag
        self.sealer = Sealer(KEY) if keyed else None
        self.generation = 0
        self.table: tuple[MemberInfo, ...] = ()
        self.sequence = 0
        self.last = b""

    def frame(self, kind: int, payload: bytes, generation: int | None = None) -> bytes:
        self.sequence += 1
        host = self.table.index(HOST) if HOST in self.table else 0
        gen = self.generation if generation is None else generation
        header = FrameHeader(kind, self.tag, HOST.member_id, gen, host, 0xFF, 2, self.sequence)
        raw = header.pack() + payload
        self.last = raw if self.sealer is None else self.sealer.seal(raw)
        return self.last

    def reset(self, order: tuple[str, ...], me: MemberInfo) -> bytes:
        members = {"node": me, "host": HOST, "other": OTHER}
        self.generation += 1
        self.table = tuple(members[name] for name in order)
        return self.frame(FrameKind.bus_reset, pack_table(self.table, HOST.member_id))

    def request(self, request: Request, node_phy: int | None) -> bytes:
        host = self.table.index(HOST) if HOST in self.table else 0
        phy = 0 if node_phy is None else node_phy
        if request.spoil == "elsewhere":
            phy = (phy + 1) % 63
        elif request.spoil == "broadcast":
            phy = 63
        bus = 0x3FE if request.spoil == "other_bus" else 0x3FF
        route: dict[str, Any] = {
            "destination_id": bus << 6 | phy,
            "tlabel": request.label,
            "source_id": 0xFFC0 | host,
            "offset": request.offset,
        }
        packet: AsyncPacket
        if request.kind == "qr":
            packet = QuadletReadRequest(**route)
        elif request.kind == "br":
            packet = BlockReadRequest(**route, data_length=request.length)
        elif request.kind == "qw":
            packet = QuadletWriteRequest(**route, quadlet_data=0x1234_5600 | request.label)
        elif request.kind == "bw":
            packet = BlockWriteRequest(
                **route, data=bytes([request.label]) * min(request.length, 4096)
            )
        else:
            packet = LockRequest(**route, data=bytes(8))
        raw = encode_packet(packet)
        if request.spoil == "damaged":
            raw = raw[:5] + bytes([raw[5] ^ 0x10]) + raw[6:]
        elif request.spoil == "short":
            raw = raw[:3]
        generation = self.generation - 1 if request.spoil == "stale" else None
        return self.frame(FrameKind.async_packet, raw, generation)

    def other(self, what: str) -> bytes | None:
        if what == "quiet":
            return None
        if what == "phy":
            return self.frame(FrameKind.phy_packet, bytes.fromhex("807f8c00 7f8073ff"))
        if what == "ack":
            return self.frame(FrameKind.ack, bytes.fromhex("11050000 00000007"))
        if what == "noise":
            return b"\x46\x57\x01" + bytes(10)
        if what == "forged":
            raw = self.frame(FrameKind.async_packet, bytes(16))
            return raw[:-1] + bytes([raw[-1] ^ 1])
        return self.last  # a copy of the last frame: a replay on a keyed bus


def run(
    script: list[Step], policy: str, keyed: bool, defects: frozenset[str] = frozenset()
) -> None:
    """Both nodes through ``script`` in lock step, compared after every step."""
    bus = Bus(keyed)
    with nodes(policy, keyed, defects) as (clock, general, express):
        settles: list[float] = []  # the general path's turns on the one-pass side

        def settle(frame: tuple[FrameHeader, bytes] | None, now: float) -> None:
            settles.append(now)
            ResponderLink.settle(express.link, frame, now)

        express.link.settle = settle  # type: ignore[method-assign]
        turns = (general.link.turn, node_turn(express.link))
        me = general.station.info
        for advance, step in [(0.0, Reset(("host", "node"))), *script]:
            clock.now += advance
            membership = general.station.membership
            if membership.generation > bus.generation:  # the node's own reset, heard
                bus.generation, bus.table = membership.generation, membership.members
            raw: bytes | None
            if isinstance(step, Reset):
                raw = bus.reset(step.order, me)
            elif isinstance(step, Request):
                raw = bus.request(step, general.station.membership.phy_id)
                for node in (general, express):
                    node.link.responder.inject_busy(step.busy)
            else:
                raw = bus.other(step.what)
            clean = isinstance(step, Request) and _clean(step, express, bus.generation)
            if isinstance(step, Frame) and step.what == "forged" and not keyed:
                # No MAC to fail on an insecure bus: a request frame of line noise.
                clean = _clean(Request("qr", 0), express, bus.generation)
            settled = len(settles)
            for node, turn in zip((general, express), turns, strict=True):
                node.medium.inbox.append(raw)
                assert turn() == clock.now
            assert state(general) == state(express)
            if not (isinstance(step, Frame) and step.what == "replay"):  # a copy of anything
                assert (len(settles) == settled) == clean, step


def _clean(request: Request, node: Node, generation: int) -> bool:
    """Whether the one-pass turn must hand ``request`` (sent in ``generation``) to the
    responder on its own: any request of the current generation once the node has a
    physical ID, whatever it asks and to whom (the responder decides the answer)."""
    return (
        request.spoil != "stale"
        and node.station.membership.phy_id is not None
        and node.station.membership.generation == generation
    )


@settings(max_examples=150, deadline=None)
@given(
    st.sampled_from(["thesis", "ieee1394", "jhu", "quick"]),
    st.booleans(),
    st.lists(steps, max_size=25),
)
def test_node_turn_serves_every_frame_as_the_general_turn(
    policy: str, keyed: bool, script: list[Step]
) -> None:
    run(script, policy, keyed)


@settings(max_examples=40, deadline=None)
@given(
    st.sampled_from(sorted({"stale-tlabel", "answers-other-node", "source-id-from-request"})),
    st.lists(steps, max_size=15),
)
def test_node_turn_of_a_defective_node_equals_the_general_turn(
    defect: str, script: list[Step]
) -> None:
    run(script, "thesis", False, frozenset({defect}))


@pytest.mark.parametrize("keyed", [False, True])
@pytest.mark.parametrize(
    "script",
    [
        # an answer no datagram carries: dropped, the ack alone goes out
        [(0.0, Request("br", 0, TOO_LARGE, label=9))],
        # timers due when a request comes: they run after its answer
        [(0.15, Request("qr", 8)), (1.2, Request("qw", 0x40)), (0.15, Request("br", 0, 64))],
        # refusals: out of the memory, misaligned
        [(0.0, Request("qr", MEMORY, label=3)), (0.0, Request("bw", 2, 6, label=4))],
        # control frames between requests: resets renumber the node, leave it out
        [
            (0.0, Request("qr", 0)),
            (0.0, Reset(("other", "host", "node"))),
            (0.0, Request("qr", 0, spoil="stale")),
            (0.0, Request("br", 8, 64)),
            (0.0, Frame("phy")),
            (0.0, Reset(("host", "other"))),
            (0.0, Request("qw", 4)),
            (0.0, Reset(("node", "host"))),
            (0.0, Request("bw", 16, 64)),
        ],
        # what a keyed bus drops, and a busy ack
        [(0.0, Frame("forged")), (0.0, Request("qr", 4)), (0.0, Frame("replay"))],
        [(0.0, Request("qw", 4, busy=1)), (0.0, Request("qw", 4))],
    ],
)
def test_scripted_turns_equal_the_general_turn(keyed: bool, script: list[Step]) -> None:
    run(script, "thesis", keyed)


def test_a_quadlet_read_is_answered_in_one_frame_by_the_one_pass_turn() -> None:
    bus = Bus(keyed=False)
    with nodes() as (clock, node, _):
        turn = node_turn(node.link)
        node.medium.inbox.append(bus.reset(("host", "node"), node.station.info))
        turn()
        node.space.write_quadlet(8, 0xCAFE_F00D)
        node.medium.sent.clear()
        node.medium.inbox.append(bus.request(Request("qr", 8, label=17), 1))
        assert turn() == clock.now
        response = QuadletReadResponse(
            destination_id=0xFFC0, tlabel=17, source_id=0xFFC1, quadlet_data=0xCAFE_F00D
        )
        sequence = 3  # after the node's self-ID and its heartbeat
        header = FrameHeader(FrameKind.ack, bus.tag, NODE_ID, 1, 1, 0, Speed.S400, sequence)
        ack = AckPayload(ack_byte(AckCode.ack_pending), 17, bus.sequence)
        assert node.medium.sent == [header.pack() + ack.pack() + encode_packet(response)]


@pytest.mark.parametrize("why", ["faults", "send"])
def test_the_general_turn_serves_what_the_one_pass_turn_cannot(why: str) -> None:
    faults = FaultConfig(duplicate=0.5) if why == "faults" else None
    with nodes(faults=faults) as (_, node, _):
        link = node.link
        if why == "send":  # frames the link sends go elsewhere than its station
            link.send = lambda kind, destination, payload: 0
        assert node_turn(link) == link.turn
