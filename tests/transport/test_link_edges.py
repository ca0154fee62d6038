"""The link's ack frames at the edges the round trips do not look at.

docs/virtual-bus.md: an ack frame's payload is the ack byte, the tlabel, a reserved
u16 (zero) and the sequence number of the frame it acknowledges, big-endian.
"""

from __future__ import annotations

import struct

from clocked_space import ClockedSpace

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import THESIS_FPGA, ReadCompleted, Requester, Responder
from fw1394.packets import QuadletReadRequest, QuadletReadResponse, QuadletWriteRequest
from fw1394.packets.fast import encode_packet
from fw1394.transport.link import RequesterLink, ResponderLink
from fw1394.transport.sansio.membership import BusReset
from fw1394.transport.sansio.wire import FrameHeader

ACK, ACK_COMPLETE_BYTE = 2, 0x1E  # frame kind 2; ack_complete and its complement
NODE_PHY, HOST_PHY = 0, 5
NODE_ID, HOST_ID = 0xFFC0, 0xFFC5


def test_a_response_behind_an_ack_frame_is_acked_complete_under_that_frames_number() -> None:
    space = MemorySpace(4096)
    space.write_quadlet(0x20, 0x0BADCAFE)
    responder_side = ResponderLink(Responder(node_id=0xFFFF, space=space, policy=THESIS_FPGA),
                                   lambda k, d, p: 0)  # fmt: skip
    responder_side.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    numbers = iter(range(1, 1 << 30))
    from_node: list[tuple[int, int, bytes]] = []
    from_host: list[tuple[int, bytes]] = []

    def to_node(kind: int, destination: int, payload: bytes) -> int:
        number = next(numbers)
        from_host.append((kind, payload))
        responder_side.take(FrameHeader(kind, 0, 7, 0, HOST_PHY, NODE_PHY, sequence=number),
                            payload, 0.0)  # fmt: skip
        return number

    requester_side = RequesterLink(Requester(node_id=HOST_ID), to_node)
    requester_side.apply([BusReset(generation=0, phy_id=HOST_PHY, members=(), initiator=0)])

    def to_host(kind: int, destination: int, payload: bytes) -> int:
        number = next(numbers)
        from_node.append((kind, number, payload))
        requester_side.take(FrameHeader(kind, 0, 8, 0, NODE_PHY, HOST_PHY, sequence=number),
                            payload, 0.0)  # fmt: skip
        return number

    responder_side.send = to_host
    read = requester_side.requester.read_quadlet(NODE_ID, 0x20, 0.0)
    requester_side.flush()
    assert ReadCompleted(read, bytes.fromhex("0badcafe")) in requester_side.requester.events()
    # The node answered with one ack frame carrying the response (a concatenated read).
    ((kind, number, payload),) = from_node
    assert kind == ACK and len(payload) > 8
    tlabel = payload[1]
    # The host acked that response complete, under the ack frame's own number.
    host_acks = [p for k, p in from_host if k == ACK]
    assert host_acks == [struct.pack(">BBHI", ACK_COMPLETE_BYTE, tlabel, 0, number)]


def test_a_decoded_packet_is_answered_like_its_bytes() -> None:
    # serve_packet (a transport that decodes once for several nodes) sends what the
    # bytes path sends: a concatenated read is one ack frame, ack_pending (0x2D) with
    # the response behind it; a unified write one ack frame, ack_complete, alone.
    space = MemorySpace(4096)
    space.write_quadlet(0x40, 0xCAFEF00D)
    sent: list[tuple[int, int, bytes]] = []
    link = ResponderLink(Responder(node_id=0xFFFF, space=space, policy=THESIS_FPGA),
                         lambda k, d, p: sent.append((k, d, p)))  # fmt: skip
    link.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    read = QuadletReadRequest(destination_id=NODE_ID, tlabel=9, source_id=HOST_ID, offset=0x40)
    link.serve_packet(read, False, HOST_PHY, 0x01020304, 0.0)
    write = QuadletWriteRequest(
        destination_id=NODE_ID, tlabel=10, source_id=HOST_ID, offset=0x44, quadlet_data=7
    )
    link.serve_packet(write, False, HOST_PHY, 0x01020305, 0.0)
    response = QuadletReadResponse(
        destination_id=HOST_ID, tlabel=9, source_id=NODE_ID, quadlet_data=0xCAFEF00D
    )
    assert sent == [
        (ACK, HOST_PHY, struct.pack(">BBHI", 0x2D, 9, 0, 0x01020304) + encode_packet(response)),
        (ACK, HOST_PHY, struct.pack(">BBHI", ACK_COMPLETE_BYTE, 10, 0, 0x01020305)),
    ]
    assert space.read_quadlet(0x44) == 7


def test_a_decoded_packet_finds_the_board_clock_counted_from_the_links_epoch() -> None:
    # As for bytes: 0.5 s after an epoch of 100 s is 0.5 s of 49.152 MHz ticks.
    space = ClockedSpace()
    link = ResponderLink(Responder(node_id=0xFFFF, space=space, policy=THESIS_FPGA),
                         lambda k, d, p: 0, epoch=100.0)  # fmt: skip
    link.apply([BusReset(generation=0, phy_id=NODE_PHY, members=(), initiator=0)])
    read = QuadletReadRequest(destination_id=NODE_ID, tlabel=1, source_id=HOST_ID, offset=0x40)
    link.serve_packet(read, False, HOST_PHY, 1, 100.5)
    assert space.clock[-1] == 49_152_000 // 2
