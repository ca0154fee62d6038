"""Planted packet-level defects: a node whose link layer gets the protocol wrong on purpose.

The fuzzer proves itself by finding these. :class:`DefectiveResponder` is a
:class:`~fw1394.engine.Responder` with a set of defect names, so the same bugs
run in-process (``inproc:`` fuzz targets) and in node processes. Board-level
defects (a register that reads wrong) belong to the boards themselves, which
receive the same set of names and ignore the ones in :data:`PACKET_DEFECTS`.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Final

from fw1394.engine import Reply, Responder, ResponderPolicy
from fw1394.engine.policy import IEEE1394_NODE
from fw1394.engine.space import AddressSpace, SpaceError
from fw1394.errors import Error
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
    Request,
    Response,
)
from fw1394.packets.nodeid import BROADCAST_PHY, bus_of, phy_of
from fw1394.packets.nodeid import node_id as make_node_id

#: The largest asynchronous payload of 1394a (S400); longer blocks are illegal.
MAX_BLOCK = 2048
_SILENT: Final = Reply(None, None, False)
_READS = (QuadletReadRequest, BlockReadRequest)
_WRITES = (QuadletWriteRequest, BlockWriteRequest)

#: Name -> what the node gets wrong. Every name is accepted by ``--defect``.
PACKET_DEFECTS: Final[dict[str, str]] = {
    "bad-crc-read-answered": "answers a read request whose CRC fails, as if it were sound",
    "bad-crc-write-performed": "performs a write whose CRC fails (answering as its policy says)",
    "wedge-after-long-block-write": (
        f"stops answering anything after a block write longer than {MAX_BLOCK} bytes"
    ),
    "answers-other-node": "serves requests addressed to another node ID as its own",
    "broadcast-read-answered": "answers read requests sent to broadcast node 63",
    "source-id-from-request": "puts the request's destination ID in its responses' source ID",
    "stale-tlabel": "gives each response the transaction label of the request before",
    "truncated-write-stale": (
        "performs a truncated block write, filling the missing quadlets with the previous "
        "write's data"
    ),
    "block-write-header-crc-unchecked": (
        "performs and acks a block write whose header CRC fails when its data CRC is right"
    ),
    "crash-on-empty-block-write": "raises an exception on a block write of 0 bytes",
}


class PlantedCrash(Error, RuntimeError):
    """The crash of ``crash-on-empty-block-write``: a node process dies of it."""


def unknown_defects(names: frozenset[str], board_defects: frozenset[str]) -> list[str]:
    """Names in ``names`` that neither this module nor the board knows, sorted."""
    return sorted(names - PACKET_DEFECTS.keys() - board_defects)


class DefectiveResponder(Responder):
    """A responder that misbehaves as ``defects`` (names of :data:`PACKET_DEFECTS`) say.

    With no defects it answers exactly as :class:`Responder`. Names it does not
    know are ignored, because the board receives the same set.
    """

    def __init__(
        self,
        node_id: int,
        space: AddressSpace,
        policy: ResponderPolicy = IEEE1394_NODE,
        *,
        generation: int = 0,
        defects: frozenset[str] = frozenset(),
    ) -> None:
        super().__init__(node_id, space, policy, generation=generation)
        self.defects = frozenset(defects) & PACKET_DEFECTS.keys()
        self.wedged = False
        self._last_block = b""
        self._last_tlabel = 0

    def receive_packet(self, packet: AsyncPacket, now: float, *, damaged: bool = False) -> Reply:
        if not self.defects:
            return super().receive_packet(packet, now, damaged=damaged)
        if self.wedged:
            return _SILENT
        if not isinstance(packet, Request):
            return super().receive_packet(packet, now, damaged=damaged)
        packet, damaged = self._before(packet, damaged)
        reply = super().receive_packet(packet, now, damaged=damaged)
        return self._after(packet, reply)

    # -- the defects, in the order a packet meets them -----------------------------------
    def _before(self, packet: Request, damaged: bool) -> tuple[Request, bool]:
        defects = self.defects
        node = phy_of(packet.destination_id)
        ours = node == phy_of(self.node_id)
        if isinstance(packet, BlockWriteRequest) and (ours or node == BROADCAST_PHY):
            self._block_write_defects(packet, damaged)
        if "answers-other-node" in defects and not ours and node != BROADCAST_PHY:
            packet = self._readdressed(packet)
            ours = True
        broadcast_read = node == BROADCAST_PHY and isinstance(packet, _READS)
        if "broadcast-read-answered" in defects and broadcast_read:
            packet = self._readdressed(packet)
            ours = True
        if damaged and ours:
            if "bad-crc-read-answered" in defects and isinstance(packet, _READS):
                damaged = False
            elif "bad-crc-write-performed" in defects and isinstance(packet, _WRITES):
                self._write(packet)
            elif "block-write-header-crc-unchecked" in defects and _only_header_crc_bad(packet):
                damaged = False
        return packet, damaged

    def _block_write_defects(self, packet: BlockWriteRequest, damaged: bool) -> None:
        defects = self.defects
        if "crash-on-empty-block-write" in defects and packet.data_length == 0:
            raise PlantedCrash("planted crash: block write of 0 bytes")
        if "wedge-after-long-block-write" in defects and packet.data_length > MAX_BLOCK:
            self.wedged = True
        short = len(packet.data) < packet.data_length
        if "truncated-write-stale" in defects and damaged and short:
            # The receive buffer still holds the previous block past what arrived.
            stale = self._last_block[len(packet.data) : packet.data_length]
            filler = stale + bytes(packet.data_length - len(packet.data) - len(stale))
            self._write(replace(packet, data=packet.data + filler))
        self._last_block = packet.data

    def _after(self, packet: Request, reply: Reply) -> Reply:
        if self.wedged:
            return _SILENT
        previous, self._last_tlabel = self._last_tlabel, packet.tlabel
        response = reply.response
        if not isinstance(response, Response):
            return reply
        if "source-id-from-request" in self.defects:
            response = replace(response, source_id=packet.destination_id)
        if "stale-tlabel" in self.defects:
            response = replace(response, tlabel=previous)
        return Reply(reply.ack, response, reply.concatenated)

    def _readdressed(self, packet: Request) -> Request:
        # The node takes the packet as its own; the CRC it carried still covers the
        # old destination, which is also what a link that skips the compare sees.
        address = make_node_id(phy_of(self.node_id), bus_of(packet.destination_id))
        return replace(packet, destination_id=address, header_crc=None)

    def _write(self, packet: Request) -> None:
        try:
            if isinstance(packet, QuadletWriteRequest):
                self.space.write_quadlet(packet.offset, packet.quadlet_data)
            elif isinstance(packet, BlockWriteRequest):
                self.space.write_block(packet.offset, packet.data)
        except SpaceError:
            pass


def _only_header_crc_bad(packet: Request) -> bool:
    if not isinstance(packet, BlockWriteRequest):
        return False
    fields = {problem.field for problem in packet.problems}
    return fields == {"header_crc"}
