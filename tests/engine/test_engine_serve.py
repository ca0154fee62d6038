"""``Responder.serve`` answers every packet as the decision table says.

Two responders over two identical address spaces get the same packets at the
same times: one through :meth:`Responder.serve` (its generated common turn
where it can), the other through :meth:`Responder.receive`, the walk of
:mod:`fw1394.engine.table`. Where ``serve`` answers with the ack frame's bytes,
those must be the ack frame the table's reply makes, written here from the
frame layout (ack byte: code and its ones' complement; tlabel; two reserved
bytes; the acknowledged frame's sequence number, big-endian) with the response
behind it; else the replies must be equal. The spaces and their clocks must
stay equal. The requests are drawn by hypothesis: every request kind, other
nodes' and broadcast destinations, foreign bus IDs, offsets in and outside the
memory, odd lengths, flipped bits and cuts, injected busy, bus resets, every
policy and a board whose registers depend on the time.

A second test takes sound requests to an in-range memory address straight to
the table's rows: the answer of :data:`ANSWERS` for ``Outcome.done`` under the
policy's delivery, silence (``SCREENS``) for other nodes' packets.
"""

from __future__ import annotations

import struct
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.registry import make_board
from fw1394.engine import Reply, Responder
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.policy import POLICIES
from fw1394.engine.table import ANSWERS, SCREENS, Delivery, Outcome, Screen
from fw1394.packets import (
    BlockReadRequest,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
)
from fw1394.packets.fast import decode_packet, encode_packet
from fw1394.packets.nodeid import node_id

MEMORY = 256
ME = 2


def ack_frame(ack: int, tlabel: int, sequence: int) -> bytes:
    """An ack frame's payload, from the frame layout (not fw1394's packer)."""
    return struct.pack(">BBHI", ack << 4 | (~ack & 0xF), tlabel, 0, sequence)


def expected_frame(reply: Reply, tlabel: int, sequence: int) -> bytes | None:
    """The one ack frame that carries ``reply`` whole; None: it needs more or nothing."""
    if reply.ack is None:
        return None
    if reply.response is None:
        return ack_frame(reply.ack, tlabel, sequence)
    if reply.concatenated:
        return ack_frame(reply.ack, tlabel, sequence) + encode_packet(reply.response)
    return None


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


def _run(served: Responder, table: Responder, script: list[Any]) -> int:
    """Both responders through ``script``; how many answers ``serve`` made itself."""
    common = 0
    for number, step in enumerate(script):
        now = 1.0 + number * 1e-4
        if isinstance(step, bytes):
            sequence = 1000 + number
            answer = served.serve(step, sequence, now)
            reply = table.receive(step, now)
            if isinstance(answer, bytes):
                common += 1
                assert answer == expected_frame(reply, step[2] >> 2, sequence), step.hex()
            else:
                assert answer == reply, step.hex()
        elif step[0] == "busy":
            for responder in (served, table):
                responder.inject_busy(step[1])
        else:
            for responder in (served, table):
                responder.bus_reset(node_id=node_id(step[1]), generation=number)
    return common


def _pair(policy: str, board: str = "memory") -> tuple[Responder, Responder]:
    def space() -> Any:
        return MemorySpace(MEMORY) if board == "memory" else make_board(board, board_id=3)

    return (
        Responder(node_id(ME), space(), POLICIES[policy]),
        Responder(node_id(ME), space(), POLICIES[policy]),
    )


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(sorted(POLICIES)), st.lists(steps, max_size=25))
def test_serve_answers_as_the_table(policy: str, script: list[Any]) -> None:
    served, table = _pair(policy)
    _run(served, table, script)
    assert served.space.read_block(0, MEMORY) == table.space.read_block(0, MEMORY)
    assert served.space.ticks == table.space.ticks  # type: ignore[attr-defined]


@settings(max_examples=60, deadline=None)
@given(st.lists(requests(), max_size=12))
def test_serve_answers_as_the_table_on_a_board(script: list[bytes]) -> None:
    # A board's registers depend on the time each request came: both get the same.
    served, table = _pair("thesis", "snake2010")
    _run(served, table, script)


@settings(max_examples=100, deadline=None)
@given(st.lists(requests(), max_size=10))
def test_a_responder_with_planted_defects_serves_by_its_own_rules(script: list[bytes]) -> None:
    defects = frozenset({"answers-other-node", "stale-tlabel"})
    served, table = (
        DefectiveResponder(node_id(ME), MemorySpace(MEMORY), POLICIES["thesis"], defects=defects)
        for _ in range(2)
    )
    assert served.common_kinds == frozenset()
    assert _run(served, table, script) == 0


@settings(max_examples=200, deadline=None)
@given(
    st.sampled_from(sorted(POLICIES)),
    st.sampled_from(["qr", "br", "qw", "bw"]),
    st.sampled_from([ME, 1]),
    st.integers(0, MEMORY // 4 - 2).map(lambda q: 4 * q),
    st.integers(0, 63),
)
def test_sound_requests_take_the_tables_row(
    policy: str, kind: str, phy: int, offset: int, tlabel: int
) -> None:
    served, _ = _pair(policy)
    route: dict[str, Any] = {"destination_id": node_id(phy), "tlabel": tlabel, "offset": offset}
    read = kind in ("qr", "br")
    packet: Any = {
        "qr": QuadletReadRequest(**route),
        "br": BlockReadRequest(**route, data_length=8),
        "qw": QuadletWriteRequest(**route, quadlet_data=0x01020304),
        "bw": BlockWriteRequest(**route, data=bytes(range(8))),
    }[kind]
    answer = served.serve(encode_packet(packet), 77, 0.5)
    policy_of = POLICIES[policy]
    row = (
        ANSWERS[Delivery(policy_of.read_mode if read else policy_of.write_mode)][Outcome.done]
        if phy == ME
        else SCREENS[Screen.not_addressed]
    )
    if row.ack is None:
        assert answer == Reply(None, None, False)
    elif isinstance(answer, bytes):
        assert answer[:8] == ack_frame(row.ack, tlabel, 77)
        if row.rcode is None:
            assert len(answer) == 8
        else:
            assert row.concatenated
            response: Any = decode_packet(answer[8:])
            assert (response.rcode, response.tlabel) == (row.rcode, tlabel)
            assert response.destination_id == packet.source_id
    else:  # a split answer: the response is a subaction of its own
        assert not row.concatenated
        assert (answer.ack, answer.concatenated) == (row.ack, False)
        assert answer.response is not None and answer.response.rcode == row.rcode  # type: ignore[attr-defined]


def test_the_thesis_policy_serves_all_four_plain_kinds_in_one_frame() -> None:
    thesis, _ = _pair("thesis")
    assert thesis.common_kinds == {0, 1, 4, 5}  # write quadlet/block, read quadlet/block
    split, _ = _pair("ieee1394")
    assert split.common_kinds == frozenset()  # it splits every answer
    read = encode_packet(QuadletReadRequest(destination_id=node_id(ME), tlabel=9, offset=4))
    answer = thesis.serve(read, 77, 0.5)
    assert isinstance(answer, bytes)
    assert answer[:8] == bytes([0x2D, 9, 0, 0, 0, 0, 0, 77])  # ack_pending, label, sequence
