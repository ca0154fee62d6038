"""The link's turn, its generation check and its keyword-only API, with a stand-in station.

Frames and ack payloads follow docs/virtual-bus.md (kinds 1 async packet, 2 ack,
3 PHY packet; an ack payload is ack byte, tlabel, reserved u16 and the acked
frame's sequence number, big-endian); ack bytes are IEEE 1394's code and its
one's complement.
"""

from __future__ import annotations

import math
import struct
from typing import cast

import pytest
from clocked_space import ClockedSpace

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import IEEE1394_NODE, THESIS_FPGA, Requester, Responder
from fw1394.packets import BlockReadRequest, BlockWriteRequest, QuadletReadRequest
from fw1394.packets.fast import encode_packet
from fw1394.transport.link import LinkLayer, RequesterLink, ResponderLink
from fw1394.transport.sansio.membership import BusReset
from fw1394.transport.sansio.seal import DropCounts
from fw1394.transport.sansio.wire import FrameHeader, FrameTooLarge
from fw1394.transport.station import Station

ASYNC, ACK, PHY = 1, 2, 3
NODE_PHY, HOST_PHY = 0, 5
NODE_ID, HOST_ID = 0xFFC0, 0xFFC5
ACK_PENDING_BYTE = 0x2D
SELF_ID = bytes.fromhex("807f00007f80ffff")
Sent = list[tuple[int, int, bytes]]


class _Membership:
    def __init__(self, generation: int, phy_id: int | None) -> None:
        self.generation = generation
        self.phy_id = phy_id


class StandInStation:
    """What a link asks of its station: frames, membership changes and timers."""

    def __init__(self, generation: int = 3, phy_id: int | None = NODE_PHY) -> None:
        self.membership = _Membership(generation, phy_id)
        self.frames: list[tuple[FrameHeader, bytes] | None] = []
        self.pending: list[object] = []
        self.serviced: list[float | None] = []
        self.deadline = 50.0
        self.wake_by = math.inf
        self.drops = DropCounts()

    def receive(self) -> tuple[FrameHeader, bytes] | None:
        return self.frames.pop(0) if self.frames else None

    def changes(self) -> list[object]:
        changes, self.pending = self.pending, []
        return changes

    def next_deadline(self) -> float:
        return self.deadline

    def service(self, now: float | None = None) -> None:
        self.serviced.append(now)


def read_request(tlabel: int = 1) -> bytes:
    return encode_packet(
        QuadletReadRequest(destination_id=NODE_ID, tlabel=tlabel, source_id=HOST_ID, offset=0x40)
    )


def responder(station: StandInStation | None = None) -> tuple[ResponderLink, Sent]:
    space = MemorySpace(4096)
    sent: Sent = []
    link = ResponderLink(
        Responder(node_id=0xFFFF, space=space, policy=THESIS_FPGA),
        lambda k, d, p: sent.append((k, d, p)),
        cast(Station, station),
    )
    link.apply([BusReset(generation=3, phy_id=NODE_PHY, members=(), initiator=0)])
    return link, sent


def request_frame(sequence: int, generation: int = 3) -> FrameHeader:
    return FrameHeader(ASYNC, 0, 7, generation, HOST_PHY, NODE_PHY, sequence=sequence)


def test_a_turn_serves_the_frame_its_station_received() -> None:
    station = StandInStation()
    link, sent = responder(station)
    station.frames.append((request_frame(41), read_request(tlabel=6)))
    link.turn()
    ((kind, destination, payload),) = sent
    assert (kind, destination) == (ACK, HOST_PHY)
    assert struct.unpack_from(">BBHI", payload) == (ACK_PENDING_BYTE, 6, 0, 41)


def test_a_quiet_turn_takes_the_stations_bus_resets_and_its_next_deadline() -> None:
    station = StandInStation()
    link, _ = responder(station)
    link.due = 100.0
    resets: list[BusReset] = []
    link.on_reset = resets.append
    reset = BusReset(generation=4, phy_id=2, members=(), initiator=0)
    station.pending.append(reset)
    link.settle(None, 1.0)
    assert resets == [reset]
    assert link.due == 50.0  # the station's deadline, sooner than the link's own
    assert station.serviced == []  # nothing is due at 1 s


def test_the_timers_run_when_the_links_own_deadline_comes() -> None:
    station = StandInStation()
    link, _ = responder(station)
    link.due = 2.0
    link.keep_timers(1.5)
    assert station.serviced == []
    now = float(2)  # equal to the deadline, not the same object
    link.keep_timers(now)
    assert station.serviced == [2.0] and link.due == 50.0


def test_a_frame_of_a_later_generation_is_not_taken() -> None:
    station = StandInStation(generation=3)
    link, sent = responder(station)
    link.receive(request_frame(1, generation=4), read_request(), 0.0)
    assert sent == []
    link.receive(request_frame(2, generation=3), read_request(), 0.0)
    assert len(sent) == 1


def test_a_requester_link_takes_no_phy_packet() -> None:
    sent: Sent = []
    link = RequesterLink(Requester(node_id=HOST_ID), lambda k, d, p: sent.append((k, d, p)))
    progress: list[None] = []
    link.on_progress = lambda: progress.append(None)
    link.take(FrameHeader(PHY, 0, 8, 3, NODE_PHY, 0xFF, sequence=1), SELF_ID, 0.0)
    assert progress == [] and sent == []


def test_a_short_ack_is_counted_malformed_by_the_station_and_harmless_without_one() -> None:
    station = StandInStation()
    link = RequesterLink(Requester(node_id=HOST_ID), lambda k, d, p: None, cast(Station, station))
    link.on_ack(NODE_PHY, 9, bytes(7), 0.0)
    assert station.drops.malformed == 1
    alone = RequesterLink(Requester(node_id=HOST_ID), lambda k, d, p: None)
    alone.on_ack(NODE_PHY, 9, bytes(7), 0.0)  # no station to count it: dropped all the same


def test_reset_hooks_and_options_take_keywords_only() -> None:
    link = LinkLayer(lambda k, d, p: None)
    with pytest.raises(TypeError):
        link.bus_reset(1, 2)  # type: ignore[call-arg]
    with pytest.raises(TypeError):
        link.excluded(2)  # type: ignore[call-arg]
    space = MemorySpace(16)
    with pytest.raises(TypeError):
        ResponderLink(Responder(node_id=0xFFFF, space=space), lambda k, d, p: None, None, 1.0)  # type: ignore[call-arg]


def test_a_block_write_with_a_bad_data_crc_is_acked_data_error_by_an_ieee1394_node() -> None:
    # IEEE 1394-1995 §6.2.4.3: ack_data_error is code 0xD, sent as 0xD2 (code, complement).
    sent: Sent = []
    link = ResponderLink(
        Responder(node_id=0xFFFF, space=MemorySpace(4096), policy=IEEE1394_NODE),
        lambda k, d, p: sent.append((k, d, p)),
    )
    link.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    write = BlockWriteRequest(
        destination_id=NODE_ID, tlabel=5, source_id=HOST_ID, offset=0x40, data=b"abcdefgh"
    )
    raw = bytearray(encode_packet(write))
    raw[-1] ^= 1  # the data CRC
    link.take(FrameHeader(ASYNC, 0, 7, 0, HOST_PHY, NODE_PHY, sequence=77), bytes(raw), 0.0)
    assert sent == [(ACK, HOST_PHY, struct.pack(">BBHI", 0xD2, 5, 0, 77))]


def test_a_decoded_read_whose_response_no_datagram_carries_is_acked_alone() -> None:
    sent: Sent = []
    dropped: list[int] = []

    def send(kind: int, destination: int, payload: bytes) -> None:
        if len(payload) > 64:
            raise FrameTooLarge(len(payload))
        sent.append((kind, destination, payload))

    link = ResponderLink(
        Responder(node_id=0xFFFF, space=MemorySpace(4096), policy=THESIS_FPGA),
        send,
        on_drop=lambda to, error: dropped.append(to),
    )
    link.apply([BusReset(generation=3, phy_id=NODE_PHY, members=(), initiator=0)])
    read = BlockReadRequest(
        destination_id=NODE_ID, tlabel=4, source_id=HOST_ID, offset=0, data_length=256
    )
    link.serve_packet(read, False, HOST_PHY, 9, 0.0)
    assert sent == [(ACK, HOST_PHY, struct.pack(">BBHI", ACK_PENDING_BYTE, 4, 0, 9))]
    assert dropped == [HOST_PHY]


def test_the_roles_reset_hooks_take_keywords_only_too() -> None:
    links = [responder()[0], RequesterLink(Requester(node_id=HOST_ID), lambda k, d, p: None)]
    for link in links:
        with pytest.raises(TypeError):
            link.bus_reset(1, 2)  # type: ignore[call-arg]
        with pytest.raises(TypeError):
            link.excluded(2)  # type: ignore[call-arg]


def test_a_new_link_runs_its_stations_timers_at_its_first_turn() -> None:
    station = StandInStation()
    link, _ = responder(station)
    link.keep_timers(0.5)
    assert station.serviced == [0.5]


def test_without_an_epoch_the_board_clock_is_the_links_time() -> None:
    space = ClockedSpace()
    link = ResponderLink(
        Responder(node_id=0xFFFF, space=space, policy=THESIS_FPGA), lambda k, d, p: None
    )
    link.apply([BusReset(generation=3, phy_id=NODE_PHY, members=(), initiator=0)])
    link.take(request_frame(1), read_request(), 2.5)
    assert space.clock[-1] == 49_152_000 * 5 // 2
