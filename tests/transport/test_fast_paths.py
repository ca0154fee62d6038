"""The link layer's fast paths send the same bytes and leave the same state as the reference.

Two responder links over two identical address spaces get the same frames; one
serves through :class:`fw1394.engine.fast_responder.FastResponder` where it
can, the other only through the general :class:`fw1394.engine.Responder`. Every
frame each link sends, and the memory behind it afterwards, must be equal.
The requests are drawn by hypothesis: every request kind, other nodes' and
broadcast destinations, foreign bus IDs, offsets in and outside the memory,
odd lengths, flipped bits, injected busy, bus resets, and every policy.
"""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.registry import make_board
from fw1394.engine import Responder
from fw1394.engine.fast_responder import FastResponder
from fw1394.engine.policy import POLICIES
from fw1394.packets import (
    BlockReadRequest,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
)
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import node_id
from fw1394.transport.link import ResponderLink
from fw1394.transport.wire import FrameHeader, FrameKind

MEMORY = 256
ME = 2


def _links(policy: str, board: str = "memory") -> tuple[list[Any], list[ResponderLink]]:
    sent: list[Any] = []
    links = []
    for path in ("fast", "reference"):

        def send(kind: int, destination: int, payload: bytes, path: str = path) -> None:
            sent.append((path, kind, destination, bytes(payload)))

        space = MemorySpace(MEMORY) if board == "memory" else make_board(board, board_id=3)
        responder = Responder(node_id(ME), space, POLICIES[policy])
        link = ResponderLink(responder, send, epoch=0.0)
        if path == "reference":
            link._fast = None  # the general engine only
        links.append(link)
    return sent, links


offsets = st.one_of(
    st.integers(0, MEMORY // 4 - 1).map(lambda q: 4 * q),
    st.integers(0, MEMORY + 8),
    st.sampled_from([0xFFFF_F000_0000, 0xFFFF_F000_0400, 1 << 40]),
)
destinations = st.tuples(st.sampled_from([0x3FF, 0, 5]), st.sampled_from([ME, ME, ME, 1, 63])).map(
    lambda bus_phy: bus_phy[0] << 6 | bus_phy[1]
)


@st.composite
def requests(draw: Any) -> bytes:
    kind = draw(st.sampled_from(["qr", "br", "qw", "bw", "lock"]))
    route = {
        "destination_id": draw(destinations),
        "tlabel": draw(st.integers(0, 63)),
        "source_id": draw(st.sampled_from([0xFFC0, 0xFFC1, 0xFFFE])),
        "offset": draw(offsets),
    }
    packet: Any
    if kind == "qr":
        packet = QuadletReadRequest(**route)
    elif kind == "br":
        packet = BlockReadRequest(**route, data_length=draw(st.integers(0, 80)))
    elif kind == "qw":
        packet = QuadletWriteRequest(**route, quadlet_data=draw(st.integers(0, (1 << 32) - 1)))
    elif kind == "bw":
        packet = BlockWriteRequest(**route, data=draw(st.binary(max_size=40)))
    else:
        operands = draw(st.binary(min_size=8, max_size=8))
        packet = LockRequest(**route, extended_tcode=2, data=operands)
    raw = bytearray(encode_packet(packet))
    if draw(st.integers(0, 5)) == 0:  # line noise: a flipped bit or a cut
        if draw(st.booleans()):
            raw[draw(st.integers(0, len(raw) - 1))] ^= 1 << draw(st.integers(0, 7))
        else:
            del raw[draw(st.integers(0, len(raw) - 1)) :]
    return bytes(raw)


steps = st.one_of(
    requests(),
    st.tuples(st.just("busy"), st.integers(1, 3)),
    st.tuples(st.just("reset"), st.sampled_from([ME, 1])),
)


def _run(sent: list[Any], links: list[ResponderLink], script: list[Any]) -> None:
    for number, step in enumerate(script):
        for link in links:
            if isinstance(step, bytes):
                header = FrameHeader(FrameKind.async_packet, 1, 7, 0, 9, ME, sequence=number)
                link.take(header, step, 1.0 + number * 1e-4)
            elif step[0] == "busy":
                link.responder.inject_busy(step[1])
            else:
                link.bus_reset(phy=step[1], generation=number)
        fast = [frame[1:] for frame in sent if frame[0] == "fast"]
        reference = [frame[1:] for frame in sent if frame[0] == "reference"]
        assert fast == reference, f"step {number}: {step!r}"
        sent.clear()


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(sorted(POLICIES)), st.lists(steps, max_size=25))
def test_fast_responder_link_equals_reference(policy: str, script: list[Any]) -> None:
    sent, links = _links(policy)
    _run(sent, links, script)
    memories = [link.responder.space.read_block(0, MEMORY) for link in links]
    assert memories[0] == memories[1]


@settings(max_examples=60, deadline=None)
@given(st.lists(requests(), max_size=12))
def test_fast_responder_equals_reference_on_a_board(script: list[bytes]) -> None:
    # A board's registers depend on the time each request came: both get the same.
    sent, links = _links("thesis", "snake2010")
    _run(sent, links, script)


def test_fast_path_serves_the_common_kinds() -> None:
    # The thesis policy answers reads and writes at once: all four plain kinds are fast.
    fast = FastResponder(Responder(node_id(ME), MemorySpace(MEMORY), POLICIES["thesis"]))
    assert fast.kinds == {0, 1, 4, 5}
    # A node that splits every answer has no fast path at all.
    split = FastResponder(Responder(node_id(ME), MemorySpace(MEMORY), POLICIES["ieee1394"]))
    assert split.kinds == frozenset()
    read = encode_packet(QuadletReadRequest(destination_id=node_id(ME), tlabel=9, offset=4))
    answer = fast.serve(read, 77, 0.5)
    assert isinstance(answer, bytes)
    assert answer[:8] == bytes([0x2D, 9, 0, 0, 0, 0, 0, 77])  # ack_pending, label, sequence
