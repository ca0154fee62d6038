"""How a request reaches a QLA board over each path: FireWire and Ethernet, as data.

One description per path of what the firmware does with the bytes it gets
(jhu-eth1394.md §3.1, §3.2): how it reads them, whether it looks at CRCs,
which destinations it takes as its own, how an offset becomes a register
address (the register map's decoding for the path) and what an answer looks
like. The Ethernet port of the emulation (:mod:`fw1394.boards.qla1.ethernet`)
serves requests through it, and the fuzzer's JHU contract
(:mod:`fw1394.fuzz.contract`) predicts answers from it, so the two cannot drift
apart.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from dataclasses import dataclass, replace

from fw1394.boards.qla1.regmap import REGISTER_MAP
from fw1394.boards.regmap import ETHERNET, FIREWIRE, Decoding
from fw1394.engine import JHU_FIRMWARE, ResponderPolicy
from fw1394.engine.responder import decode_received
from fw1394.packets import (
    AsyncPacket,
    BlockReadResponse,
    BlockWriteRequest,
    PacketError,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    Request,
    Response,
)
from fw1394.packets.asynchronous import tcode_of
from fw1394.packets.enums import TCode
from fw1394.packets.fast import decode_packet, encode_packet
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS, bus_of
from fw1394.packets.nodeid import node_id as node_id_of

#: A quadlet read shorter than its 16 bytes is still answered from 14 bytes on: the
#: register read starts at the last word the UDP length announces (§3.2).
SHORT_QREAD_MINIMUM = 14
QREAD_SIZE = 16
#: A quadlet read of its three header quadlets only: the stale-data read (§3.2).
STALE_QREAD_SIZE = 12
_WRITES = (QuadletWriteRequest, BlockWriteRequest)


@dataclass(frozen=True)
class Path:
    """What one path into the board does with a request, as the firmware does it."""

    name: str
    #: How an offset becomes a register address (the register map's, for this path).
    decoding: Decoding
    #: How the board answers what reaches it.
    policy: ResponderPolicy
    #: The bytes as this path reads them: (request or None, damaged by CRC or length).
    read: Callable[[bytes], tuple[AsyncPacket | None, bool]]
    #: CRC and length problems count (FireWire acks them ack_data_error); the
    #: Ethernet path never looks at a CRC.
    checks_crc: bool
    #: The destination bus a request must name (None: any; the FireWire link ignores it).
    bus: int | None
    #: Broadcast reads are answered (the Ethernet hub does, with no-forward set).
    answers_broadcast_reads: bool
    #: Responses carry real CRCs (FireWire) or zeros (the Ethernet path).
    response_crcs: bool
    #: Writes are answered at all (FireWire acks them; Ethernet sends nothing).
    answers_writes: bool
    #: A quadlet read cut after its header is answered with the data the previous
    #: quadlet read returned, no register read (the Ethernet path, §3.2); FireWire
    #: drops it as too short.
    answers_stale_reads: bool = False

    def stale_read(self, raw: bytes) -> QuadletReadRequest | None:
        """The quadlet read ``raw`` names when it is this path's stale-data read, else None."""
        if not (
            self.answers_stale_reads
            and len(raw) == STALE_QREAD_SIZE
            and tcode_of(raw) == TCode.read_quadlet_request
        ):
            return None
        packet = decode_packet(raw.ljust(QREAD_SIZE, b"\0"))
        return packet if isinstance(packet, QuadletReadRequest) else None

    @staticmethod
    def stale_response(request: QuadletReadRequest, last_read: int) -> QuadletReadResponse:
        """The stale-data read's answer: ``request``'s label and addresses, ``last_read``."""
        return QuadletReadResponse(
            destination_id=request.source_id,
            tlabel=request.tlabel,
            source_id=request.destination_id,
            quadlet_data=last_read,
        )

    def takes(self, packet: Request, own_node: int) -> bool:
        """Whether ``packet`` is for the board whose node (Ethernet: board id) is ``own_node``."""
        if self.bus is not None and packet.destination_bus != self.bus:
            return False
        destination = packet.destination_node
        if destination == own_node:
            return True
        if destination != BROADCAST_PHY:
            return False
        return isinstance(packet, _WRITES) or self.answers_broadcast_reads

    def for_board(self, packet: Request, responder_node: int) -> Request:
        """The request as the board's responder gets it: offset decoded, addressed to it.

        ``responder_node`` is the responder's 6-bit node number. Broadcast writes stay
        broadcast (every board performs them); anything else the path took is the
        board's own.
        """
        offset = _decoded(self.decoding, packet.offset)
        if isinstance(packet, _WRITES) and packet.destination_node == BROADCAST_PHY:
            return replace(packet, offset=offset) if offset != packet.offset else packet
        destination = node_id_of(responder_node, bus_of(packet.destination_id))
        return replace(packet, offset=offset, destination_id=destination)

    def answer_source(self, request: Request, reply_node: int) -> int | None:
        """The source ID a response to ``request`` leaves with from node ``reply_node``
        over this path; None: the responder's own."""
        if self.response_crcs:
            return None
        # The Ethernet path names {destination bus of the request, reply node}.
        return node_id_of(reply_node, bus_of(request.destination_id))

    def answer(self, response: Response, request: Request, reply_node: int) -> Response:
        """``response`` as it leaves over this path, from node ``reply_node``."""
        source = self.answer_source(request, reply_node)
        return response if source is None else replace(response, source_id=source)


@functools.lru_cache(maxsize=8192)
def _decoded(decoding: Decoding, offset: int) -> int:
    return decoding.address(offset)


# Every board of a rack reads the same multicast datagram: decode it once.
@functools.lru_cache(maxsize=256)
def read_ethernet(raw: bytes) -> tuple[AsyncPacket | None, bool]:
    """A request as EthernetIO reads it: leniently, and never damaged (no CRC is checked)."""
    try:
        return decode_packet(raw), False
    except PacketError:
        pass
    if SHORT_QREAD_MINIMUM <= len(raw) < QREAD_SIZE and tcode_of(raw) == TCode.read_quadlet_request:
        return decode_packet(raw.ljust(QREAD_SIZE, b"\0")), False
    return None, False


#: Where a read response's header CRC sits: after quadlets 0..3.
_HEADER_CRC = slice(16, 20)
_NO_CRC = bytes(4)


def zero_crc_bytes(response: Response) -> bytes:
    """A response as the firmware's Ethernet path sends it: both CRC quadlets 0."""
    # Encoded as usual (the quick path), then the CRC quadlets cleared.
    raw = bytearray(encode_packet(response))
    raw[_HEADER_CRC] = _NO_CRC
    if isinstance(response, BlockReadResponse):
        raw[-4:] = _NO_CRC
    return bytes(raw)


def zero_crc_block_response(
    destination_id: int, tlabel: int, source_id: int, reserved: int, data: bytes
) -> bytes:
    """:func:`zero_crc_bytes` of the complete :class:`BlockReadResponse` carrying ``data``.

    The header of a response depends on its addresses, label and length only: it is
    encoded once for each of them (the hub answers the same host with the same few
    labels and sizes every cycle) and the data put behind it as it is.
    """
    if len(data) % 4:
        return zero_crc_bytes(
            BlockReadResponse(
                destination_id=destination_id,
                tlabel=tlabel,
                source_id=source_id,
                reserved=reserved,
                data=data,
            )
        )
    head = _block_response_head(destination_id, tlabel, source_id, reserved, len(data))
    return b"".join((head, data, _NO_CRC))


@functools.lru_cache(maxsize=1024)
def _block_response_head(
    destination_id: int, tlabel: int, source_id: int, reserved: int, length: int
) -> bytes:
    response = BlockReadResponse(
        destination_id=destination_id,
        tlabel=tlabel,
        source_id=source_id,
        reserved=reserved,
        data=bytes(length),
    )
    return zero_crc_bytes(response)[: _HEADER_CRC.stop]


#: The FireWire link (FireWire.v): the responder policy does all the screening.
FIREWIRE_PATH = Path(
    name=FIREWIRE,
    decoding=REGISTER_MAP.decodings[FIREWIRE],
    policy=JHU_FIRMWARE,
    read=decode_received,
    checks_crc=True,
    bus=None,
    answers_broadcast_reads=False,
    response_crcs=True,
    answers_writes=True,
)

#: EthernetIO with the no-forward flag set (Ethernet-only mode, and what a fuzzer
#: sends): destination bus 0x3FF, node = board id, broadcast reads answered by the
#: hub, no CRC checked, 16 offset bits, zero CRCs out, no answer to writes.
ETHERNET_PATH = Path(
    name=ETHERNET,
    decoding=REGISTER_MAP.decodings[ETHERNET],
    # The bus ID is checked (0x3FF) before anything reaches the board.
    policy=replace(JHU_FIRMWARE, ignore_bus_id=False),
    read=read_ethernet,
    checks_crc=False,
    bus=LOCAL_BUS,
    answers_broadcast_reads=True,
    response_crcs=False,
    answers_writes=False,
    answers_stale_reads=True,
)

PATHS = {path.name: path for path in (FIREWIRE_PATH, ETHERNET_PATH)}
