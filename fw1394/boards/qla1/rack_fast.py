"""A rack's real-time cycle in one pass: the fast path of :meth:`Rack.receive_everywhere`.

In Ethernet-only mode (firmware 9 on) the host's real-time loop sends two
multicasts a cycle, each taken by every board: the broadcast query (a quadlet
write of ``sequence << 16 | board mask`` to 0x1800) and the broadcast write of
every board's DAC and control block to offset 0. The general path serves the
datagram port by port, as separate boards would: it decodes it once per board,
hands each board's hub broadcast to every other board (N x N hand-overs, most
of them kept for a query that has not reached that board yet) and walks the
whole write block once per board. Here the rack does the same in one pass: each
board samples its block once and every hub gets the same frozen copies, and the
write block is split among the boards in one walk.

Bridge mode (firmware 8 and before) has the same two broadcasts, sent to the
hub without no-forward: the hub performs each and forwards it onto FireWire,
where every board performs it too, and after a query every board broadcasts
its block on FireWire for every other board's hub (N x N again).
:meth:`RackFastPath.bridge` does that in one pass as well: each board samples
its block once, every hub keeps the same frozen copies in the order the
forwarded broadcasts would bring them, and the write block is split once
(Rev 8) or decoded once per board (Rev 7 and before).

Only the host's ordinary cycle is taken: no-forward set, destination 0xFFFF,
offsets exactly 0x1800 and 0, a query naming every board of the rack and none
that a hub is already collecting, boards without planted defects, and ports
with nothing of an earlier round in flight. For anything else :meth:`receive`
returns None before touching anything, and the general path, the reference,
serves it. Tests hold both equal with hypothesis: the same replies, the same
state of every board, responder and port afterwards.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

from fw1394.boards.qla1.ethernet import EthernetPort, HostAddress, Reply, decode_request
from fw1394.boards.qla1.hub import reporting_board
from fw1394.boards.qla1.rack_member import RackBoard
from fw1394.boards.qla1.regs import HUB_QUERY
from fw1394.boards.qla1.rt_blocks import (
    RtWrite,
    decode_old_write,
    decode_rev7_write,
    split_rev8_write,
)
from fw1394.packets import BlockWriteRequest, QuadletWriteRequest
from fw1394.packets.eth1394 import Eth1394Error, Eth1394Request
from fw1394.packets.eth1394_fast import split_request
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS
from fw1394.packets.nodeid import node_id as node_id_of
from fw1394.transport.eth1394_addresses import MULTICAST_FIRMWARE

#: The destination of the host's broadcasts: every node of the local bus.
HOST_BROADCAST = node_id_of(BROADCAST_PHY, LOCAL_BUS)
#: Where the real-time write block goes (the first DAC block starts there).
RT_WRITE_OFFSET = 0
#: The share of a board the write block has nothing for.
NO_WRITE = RtWrite()
_BOARD_MASK = 0xFFFF


class RackFastPath:
    """The host's real-time multicasts for every board of ``members`` at once."""

    def __init__(self, members: Sequence[RackBoard], firmware: int) -> None:
        ports = [member.port for member in members]
        self._ports: list[EthernetPort] = [port for port in ports if port is not None]
        # Before firmware 9 only the hub is cabled: the other boards are FireWire's.
        self._enabled = firmware >= MULTICAST_FIRMWARE and len(self._ports) == len(members)
        self._bridge = firmware < MULTICAST_FIRMWARE and len(self._ports) == 1
        self._firmware = firmware
        self._members = list(members)
        self._boards = [member.board for member in members]
        self._board_ids = [board.board_id for board in self._boards]
        self._mask = sum(1 << board_id for board_id in self._board_ids)
        self._hub = next((n for n, port in enumerate(self._ports) if port.ethernet_hub), 0)

    def receive(
        self, payload: bytes, sender: HostAddress, now: float
    ) -> list[tuple[int, Reply]] | None:
        """Replies (by port index) to a datagram every port got; None: not taken."""
        if not self._enabled:
            return None
        try:
            framed = split_request(payload)
        except Eth1394Error:
            return None
        if not framed.control.no_forward:
            return None
        packet = decode_request(framed.packet)
        if packet is None or packet.destination_id != HOST_BROADCAST:
            return None
        if any([board.defects for board in self._boards]):
            return None
        if type(packet) is QuadletWriteRequest and packet.offset == HUB_QUERY:
            return self._query(packet, sender, now)
        if type(packet) is BlockWriteRequest and packet.offset == RT_WRITE_OFFSET:
            self._write(packet, sender, now)
            return []
        return None

    def _query(
        self, query: QuadletWriteRequest, sender: HostAddress, now: float
    ) -> list[tuple[int, Reply]] | None:
        value = query.quadlet_data
        sequence = value >> 16
        if value & _BOARD_MASK != self._mask:
            return None
        for member, port in zip(self._members, self._ports, strict=True):
            hub = member.board.hub
            # A hub already on this sequence would take early blocks into the old round.
            if not port.quiet or (hub.sequence == sequence and hub.board_mask):
                return None
        for member, port in zip(self._members, self._ports, strict=True):
            port.last_host, port.host_id = sender, query.source_id
            member.responder.advance_clock(now)
            member.board.take_query(value)
        self._share_blocks()
        return [(self._hub, self._ports[self._hub].answer_query(query, sender, now))]

    def _share_blocks(self) -> None:
        """Every board's block of this round, as its query stored it (what its broadcast
        carries), kept by every other board's hub in the order the broadcasts come."""
        members = self._members
        if len(members) < 2:
            return  # nobody to share with
        blocks = []
        for member in members:
            board = member.board
            block = board.hub.blocks[board.board_id]
            blocks.append((reporting_board(block.quadlets), block))
        round_blocks = dict(blocks)
        if list(round_blocks) == self._board_ids:
            # Each block says whose it is: every hub holds its own block, then the
            # others in board-index order, which is what one update of it gives.
            for member in members:
                member.board.keep_hub_round(round_blocks)
            return
        for n, member in enumerate(members):
            # Earlier boards' broadcasts were kept for this query, later ones arrive after it.
            member.board.keep_hub_blocks(blocks[:n] + blocks[n + 1 :])

    def _write(self, packet: BlockWriteRequest, sender: HostAddress, now: float) -> None:
        data = packet.data
        words = struct.unpack_from(f">{len(data) // 4}I", data)
        shares = split_rev8_write(words, RT_WRITE_OFFSET)
        for member, port in zip(self._members, self._ports, strict=True):
            port.last_host, port.host_id = sender, packet.source_id
            member.responder.advance_clock(now)
            member.board.apply_rt_write(shares.get(member.board.board_id, NO_WRITE))

    # -- bridge mode ----------------------------------------------------------------------
    def bridge(
        self, payload: bytes, sender: HostAddress, now: float, resetting: bool
    ) -> list[tuple[int, Reply]] | None:
        """Replies to a datagram the hub got in bridge mode; None: not taken.

        Takes the host's broadcast query (naming every board) and broadcast write
        without no-forward, when the bus is not resetting and nothing is damaged.
        """
        if not self._bridge or resetting:
            return None
        try:
            framed = split_request(payload)
        except Eth1394Error:
            return None
        return self.bridge_framed(framed, sender, now, resetting)

    def bridge_framed(
        self, framed: Eth1394Request, sender: HostAddress, now: float, resetting: bool
    ) -> list[tuple[int, Reply]] | None:
        """:meth:`bridge` of a datagram split into control word and packet already."""
        if not self._bridge or resetting:
            return None
        if framed.control.no_forward:
            return None
        packet = decode_request(framed.packet)
        if packet is None or packet.destination_id != HOST_BROADCAST or packet.problems:
            return None
        if any([board.defects for board in self._boards]):
            return None
        hub = self._ports[0]
        if type(packet) is QuadletWriteRequest and packet.offset == HUB_QUERY:
            value = packet.quadlet_data
            if value & _BOARD_MASK != self._mask or not hub.quiet:
                return None
            sequence = value >> 16
            if any(m.board.hub.sequence == sequence and m.board.hub.board_mask
                   for m in self._members):  # fmt: skip
                return None
            hub.last_host, hub.host_id = sender, packet.source_id
            for member in self._members:
                member.responder.advance_clock(now)
                member.board.take_query(value)
            # The forwarded broadcasts come in board-index order, each hub's own first.
            self._share_blocks()
            return []
        if type(packet) is BlockWriteRequest and packet.offset == RT_WRITE_OFFSET:
            hub.last_host, hub.host_id = sender, packet.source_id
            data = packet.data
            words = struct.unpack_from(f">{len(data) // 4}I", data)
            if not words:
                for member in self._members:
                    member.responder.advance_clock(now)
                return []
            shares = split_rev8_write(words, RT_WRITE_OFFSET) if self._firmware >= 8 else None
            for member in self._members:
                board = member.board
                member.responder.advance_clock(now)
                if shares is not None:
                    write = shares.get(board.board_id, NO_WRITE)
                elif self._firmware == 7:
                    write = decode_rev7_write(words, board.board_id)
                else:
                    write = decode_old_write(words, board.board_id)
                board.apply_rt_write(write)
            return []
        return None
