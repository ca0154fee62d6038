"""The link layer without sockets: request frames in, ack and response frame bytes out.

Frames are checked byte by byte against the tunnel format of docs/virtual-bus.md
(ack payload: ack byte, tlabel, reserved u16, acked sequence number, then any
concatenated response) and against packets built by fw1394.packets' codec.
"""

from __future__ import annotations

import struct
from typing import cast

import pytest
from clocked_space import ClockedSpace

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import (
    IEEE1394_NODE,
    THESIS_FPGA,
    FailureReason,
    ReadCompleted,
    Requester,
    Responder,
    TransactionFailed,
    WriteCompleted,
)
from fw1394.packets import (
    BlockReadRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
)
from fw1394.packets.fast import decode_packet, encode_packet
from fw1394.transport.link import BusRefusedError, RequesterLink, ResponderLink
from fw1394.transport.sansio.membership import BusReset, Excluded, Refused
from fw1394.transport.sansio.wire import FrameHeader, FrameTooLarge
from fw1394.transport.station import Station

# Wire bytes of acks (IEEE 1394-1995 §6.2.4.3: code, then its one's complement).
ACK_COMPLETE_BYTE = 0x1E
ACK_PENDING_BYTE = 0x2D
NODE_PHY, HOST_PHY = 0, 5
NODE_ID, HOST_ID = 0xFFC0, 0xFFC5
Sent = list[tuple[int, int, bytes]]


def responder_link(policy: object = THESIS_FPGA) -> tuple[ResponderLink, MemorySpace, Sent]:
    space = MemorySpace(4096)
    responder = Responder(node_id=0xFFFF, space=space, policy=policy)  # type: ignore[arg-type]
    sent: Sent = []
    link = ResponderLink(responder, lambda k, d, p: sent.append((k, d, p)))
    link.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    return link, space, sent


def frame(sequence: int, kind: int = 1) -> FrameHeader:
    return FrameHeader(kind, 0, 7, 0, HOST_PHY, NODE_PHY, sequence=sequence)


def test_a_concatenated_read_is_one_ack_frame_carrying_the_response() -> None:
    link, space, sent = responder_link(THESIS_FPGA)
    space.write_quadlet(0x40, 0xCAFEF00D)
    request = QuadletReadRequest(destination_id=NODE_ID, tlabel=9, source_id=HOST_ID, offset=0x40)
    link.take(frame(sequence=0x01020304), encode_packet(request), 0.0)
    assert len(sent) == 1
    kind, destination, payload = sent[0]
    assert (kind, destination) == (2, HOST_PHY)  # an ack frame, back to the requester
    assert payload[:8] == bytes([ACK_PENDING_BYTE, 9, 0, 0, 1, 2, 3, 4])
    expected = QuadletReadResponse(
        destination_id=HOST_ID, tlabel=9, source_id=NODE_ID, quadlet_data=0xCAFEF00D
    )
    assert payload[8:] == encode_packet(expected)


def test_a_split_read_is_an_ack_then_a_response_packet() -> None:
    link, space, sent = responder_link(IEEE1394_NODE)
    space.write_quadlet(0x10, 0x11223344)
    request = QuadletReadRequest(destination_id=NODE_ID, tlabel=3, source_id=HOST_ID, offset=0x10)
    link.take(frame(sequence=77), encode_packet(request), 0.0)
    assert [(k, d) for k, d, _ in sent] == [(2, HOST_PHY), (1, HOST_PHY)]
    assert sent[0][2] == struct.pack(">BBHI", ACK_PENDING_BYTE, 3, 0, 77)
    response = decode_packet(sent[1][2])
    assert isinstance(response, QuadletReadResponse)
    assert (response.tlabel, response.quadlet_data) == (3, 0x11223344)


def test_a_unified_write_is_acked_complete_and_done() -> None:
    link, space, sent = responder_link(THESIS_FPGA)
    request = QuadletWriteRequest(
        destination_id=NODE_ID, tlabel=63, source_id=HOST_ID, offset=8, quadlet_data=0xA5A5A5A5
    )
    link.take(frame(sequence=5), encode_packet(request), 0.0)
    assert sent == [(2, HOST_PHY, struct.pack(">BBHI", ACK_COMPLETE_BYTE, 63, 0, 5))]
    assert space.read_quadlet(8) == 0xA5A5A5A5


def test_line_noise_and_other_frame_kinds_get_no_answer() -> None:
    link, _, sent = responder_link()
    link.take(frame(sequence=1), b"\x00\x01", 0.0)
    request = QuadletReadRequest(destination_id=NODE_ID, tlabel=1, source_id=HOST_ID, offset=0)
    link.take(frame(sequence=2, kind=2), encode_packet(request), 0.0)  # an ack frame
    assert sent == []


def test_a_response_no_datagram_carries_is_dropped_and_the_ack_still_goes() -> None:
    space = MemorySpace(4096)
    responder = Responder(node_id=NODE_ID, space=space, policy=THESIS_FPGA)
    sent: Sent = []
    dropped: list[tuple[int, int]] = []

    def send(kind: int, destination: int, payload: bytes) -> None:
        if len(payload) > 64:
            raise FrameTooLarge(len(payload))
        sent.append((kind, destination, payload))

    link = ResponderLink(responder, send, on_drop=lambda to, e: dropped.append((to, e.size)))
    request = BlockReadRequest(
        destination_id=NODE_ID, tlabel=4, source_id=HOST_ID, offset=0, data_length=256
    )
    link.take(frame(sequence=9), encode_packet(request), 0.0)
    assert sent == [(2, HOST_PHY, struct.pack(">BBHI", ACK_PENDING_BYTE, 4, 0, 9))]
    assert len(dropped) == 1 and dropped[0][0] == HOST_PHY and dropped[0][1] > 256


def test_reset_hooks_give_the_engines_their_node_id_and_generation() -> None:
    link, _, _ = responder_link()
    seen: list[BusReset] = []
    link.on_reset = seen.append
    reset = BusReset(generation=4, phy_id=2, members=(), initiator=0)
    link.apply([reset])
    assert (link.responder.node_id, link.responder.generation) == (0xFFC2, 4)
    assert seen == [reset]
    with pytest.raises(BusRefusedError, match="full"):
        link.apply([Refused("the bus is full")])


def connected(policy: object) -> tuple[RequesterLink, ResponderLink, MemorySpace]:
    """A requester link and a responder link whose sends reach each other at once."""
    responder_side, space, _ = responder_link(policy)
    requester = Requester(node_id=HOST_ID, ack_timeout=1.0, split_timeout=1.0)
    sequence = iter(range(1, 1 << 30))

    def to_responder(kind: int, destination: int, payload: bytes) -> int:
        assert destination == NODE_PHY
        number = next(sequence)
        header = FrameHeader(kind, 0, 7, 0, HOST_PHY, NODE_PHY, sequence=number)
        responder_side.take(header, payload, 0.0)
        return number

    requester_side = RequesterLink(requester, to_responder)

    def to_requester(kind: int, destination: int, payload: bytes) -> int:
        assert destination == HOST_PHY
        number = next(sequence)
        header = FrameHeader(kind, 0, 8, 0, NODE_PHY, HOST_PHY, sequence=number)
        requester_side.take(header, payload, 0.0)
        return number

    responder_side.send = to_requester
    return requester_side, responder_side, space


@pytest.mark.parametrize("policy", [THESIS_FPGA, IEEE1394_NODE], ids=["concatenated", "split"])
def test_requester_and_responder_links_complete_transactions(policy: object) -> None:
    link, _, space = connected(policy)
    requester = link.requester
    write = requester.write_quadlet(NODE_ID, 0x20, 0x0BADCAFE, 0.0)
    link.flush()
    read = requester.read_quadlet(NODE_ID, 0x20, 0.0)
    link.flush()
    events = requester.events()
    assert WriteCompleted(write) in events
    assert ReadCompleted(read, bytes.fromhex("0badcafe")) in events
    assert space.read_quadlet(0x20) == 0x0BADCAFE
    assert requester.outstanding == 0


def test_a_split_write_response_is_acked_back_to_the_responder() -> None:
    link, _, _ = connected(IEEE1394_NODE)
    acks: list[bytes] = []
    deliver = link.send

    def recording(kind: int, destination: int, payload: bytes) -> object:
        if kind == 2:
            acks.append(payload)
        return deliver(kind, destination, payload)

    link.send = recording
    link.requester.write_quadlet(NODE_ID, 0, 1, 0.0)
    link.flush()
    # The write response came as a packet of its own; the requester acked it complete.
    assert len(acks) == 1 and acks[0][:2] == bytes([ACK_COMPLETE_BYTE, 0])
    assert any(isinstance(e, WriteCompleted) for e in link.requester.events())


def test_an_exclusion_fails_what_is_outstanding() -> None:
    requester = Requester(node_id=HOST_ID)
    link = RequesterLink(requester, lambda k, d, p: 1)
    tid = requester.read_quadlet(NODE_ID, 0, 0.0)
    link.flush()
    link.apply([Excluded(generation=3)])
    (event,) = requester.events()
    assert isinstance(event, TransactionFailed) and event.transaction == tid
    assert event.reason == FailureReason.bus_reset


class _Membership:
    def __init__(self) -> None:
        self.generation = 2
        self.phy_id: int | None = 1


class _Station:
    def __init__(self) -> None:
        self.membership = _Membership()


def test_frames_of_another_generation_never_reach_the_engine() -> None:
    space = MemorySpace(4096)
    responder = Responder(node_id=0xFFC1, space=space, policy=THESIS_FPGA)
    sent: Sent = []
    fake = _Station()
    station = cast(Station, fake)
    link = ResponderLink(responder, lambda k, d, p: sent.append((k, d, p)), station)
    raw = encode_packet(
        QuadletReadRequest(destination_id=0xFFC1, tlabel=0, source_id=HOST_ID, offset=0)
    )
    link.receive(FrameHeader(1, 0, 7, 1, HOST_PHY, 1, sequence=1), raw, 0.0)
    assert sent == []
    link.receive(FrameHeader(1, 0, 7, 2, HOST_PHY, 1, sequence=2), raw, 0.0)
    assert len(sent) == 1
    fake.membership.phy_id = None  # between generations: no address, nothing taken
    link.receive(FrameHeader(1, 0, 7, 2, HOST_PHY, 1, sequence=3), raw, 0.0)
    assert len(sent) == 1


@pytest.mark.parametrize("flip", [0, 2, 15], ids=["destination", "tlabel", "quadlet-data"])
def test_a_damaged_response_is_discarded_unacked(flip: int) -> None:
    requester = Requester(node_id=HOST_ID, ack_timeout=1.0, split_timeout=1.0)
    sent: Sent = []
    link = RequesterLink(requester, lambda k, d, p: sent.append((k, d, p)))
    tid = requester.read_quadlet(NODE_ID, 0x40, 0.0)
    link.flush()
    ((_, _, raw),) = sent
    label = decode_packet(raw).tlabel  # type: ignore[attr-defined]
    response = bytearray(
        encode_packet(
            QuadletReadResponse(
                destination_id=HOST_ID, tlabel=label, source_id=NODE_ID, quadlet_data=0xCAFEF00D
            )
        )
    )
    response[flip] ^= 0x04  # one bit the header CRC covers
    ack = bytes([ACK_PENDING_BYTE, label, 0, 0, 0, 0, 0, 9])
    link.take(FrameHeader(2, 0, 8, 0, NODE_PHY, HOST_PHY, sequence=9), ack + response, 0.0)
    # No completion with wrong bytes, and no ack for a packet the link cannot trust.
    assert len(sent) == 1
    assert not [e for e in requester.events() if isinstance(e, ReadCompleted)]
    requester.handle_timer(1.5)
    (failure,) = requester.events()
    assert isinstance(failure, TransactionFailed) and failure.transaction == tid
    assert failure.reason == FailureReason.response_timeout


class _ReferenceResponder(Responder):
    """The same rules, but not the class the link's fast path takes."""


@pytest.mark.parametrize("responder_class", [Responder, _ReferenceResponder])
def test_the_board_clock_counts_from_the_links_epoch(responder_class: type[Responder]) -> None:
    # The boards count 49.152 MHz ticks (thesis §6.3) from their node's start, so a
    # request arriving 0.5 s after an epoch of 100 s finds the clock at 0.5 s of ticks,
    # on the fast path and on the reference path alike.
    space = ClockedSpace()
    responder = responder_class(node_id=0xFFFF, space=space, policy=THESIS_FPGA)
    sent: Sent = []
    link = ResponderLink(responder, lambda k, d, p: sent.append((k, d, p)), epoch=100.0)
    link.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    request = QuadletReadRequest(destination_id=NODE_ID, tlabel=1, source_id=HOST_ID, offset=0x40)
    link.take(frame(sequence=1), encode_packet(request), 100.5)
    assert sent and space.clock[-1] == 49_152_000 // 2


class _DelayingStation:
    """A station holding one delayed frame due at ``wake_by``; it counts its services."""

    def __init__(self, wake_by: float) -> None:
        self.wake_by = wake_by
        self.serviced: list[float | None] = []

    def service(self, now: float | None = None) -> None:
        self.serviced.append(now)

    def changes(self) -> list[object]:
        return []

    def next_deadline(self) -> float:
        return 10.0


def test_the_timers_run_once_a_delayed_frame_is_due_and_not_before() -> None:
    # Station.wake_by: owners call service() by then, even when no timer of the
    # membership is due yet (here at 10 s).
    station = _DelayingStation(wake_by=5.0)
    link = ResponderLink(Responder(node_id=0xFFFF, space=MemorySpace(16)), lambda k, d, p: None)
    link.station = cast(Station, station)
    link.due = 10.0
    link.keep_timers(4.0)
    assert station.serviced == []
    link.keep_timers(6.0)
    assert station.serviced == [6.0]
