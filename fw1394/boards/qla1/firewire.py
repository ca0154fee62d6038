"""What a JHU board does on its FireWire side beyond answering requests.

Two firmware behaviours the engine's :class:`~fw1394.engine.Responder` has no
notion of live here:

* the broadcast query: a quadlet write to 0x1800 (broadcast, or to node 0;
  before firmware 7 the FireWire host writes node 0 at 0xFFFF_FFFF_000F
  instead) is taken by every board, and each board named in the query's mask
  then broadcasts its real-time block (a block write to 0xFFFF_FF00_1000,
  marked with priority 0xA) for the hub to collect (jhu-eth1394.md §4.8);
* the "fake broadcast": the FireWire host writes every board's real-time block
  as one block write to node 0 at 0xFFFF_FFFF_0000, and every board snoops it
  and takes its own part (§3.1, §3.3 item 7);
* one clock per board: the Ethernet and FireWire paths of a board share
  one responder, and :class:`ClockedBoard` lets either of them move the
  board's time forward without ever moving it back.
"""

from __future__ import annotations

import functools
import struct
from dataclasses import replace
from typing import Protocol

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.regmap import FIREWIRE_DECODING
from fw1394.boards.qla1.regs import (
    FAKE_BROADCAST_OFFSET,
    HUB_MEMORY_BASE,
    HUB_QUERY,
    OLD_QUERY_LAST_FIRMWARE,
    OLD_QUERY_OFFSET,
)
from fw1394.packets import AsyncPacket, BlockWriteRequest, QuadletWriteRequest, Request
from fw1394.packets.nodeid import BROADCAST_ID, BROADCAST_PHY, LOCAL_BASE, phy_of
from fw1394.packets.nodeid import node_id as node_id_of

_register_address = functools.lru_cache(maxsize=4096)(FIREWIRE_DECODING.address)

#: Node ID of physical ID 0 on the local bus; a node ID is this ORed with the physical ID.
LOCAL_BUS_IDS = LOCAL_BASE
#: Offset of the hub-data broadcast: hub memory, seen through the upper address bits.
HUB_BROADCAST_OFFSET = 0xFFFF_FF00_0000 | HUB_MEMORY_BASE
#: The priority field the firmware sets on its own hub-data broadcasts.
HUB_BROADCAST_PRIORITY = 0xA


class FireWireState(Protocol):
    """What a board's Ethernet path needs to know of its FireWire bus."""

    @property
    def node_id(self) -> int:
        """The board's 6-bit physical ID."""
        ...

    @property
    def generation(self) -> int:
        """Bus generation (the firmware counts bus resets in 8 bits)."""
        ...

    @property
    def resetting(self) -> bool:
        """A bus reset is in progress."""
        ...


class NoFireWire:
    """A board with no FireWire cable (Ethernet-only mode): node 0, generation 0."""

    node_id = 0
    generation = 0
    resetting = False


class ClockedBoard:
    """A :class:`Qla1Board` whose clock only moves forward, whoever sets it.

    The engine's responder keeps its own idea of the last time it set; a
    board served by two paths (or read between requests) would otherwise be
    asked to go back in time, which it refuses.
    """

    def __init__(self, board: Qla1Board) -> None:
        self.board = board

    def set_time(self, ticks: int) -> None:
        self.board.advance_to(ticks)

    def read_quadlet(self, offset: int) -> int:
        return self.board.read_quadlet(offset)

    def write_quadlet(self, offset: int, value: int) -> None:
        self.board.write_quadlet(offset, value)

    def read_block(self, offset: int, length: int) -> bytes:
        return self.board.read_block(offset, length)

    def write_block(self, offset: int, data: bytes) -> None:
        self.board.write_block(offset, data)


def is_hub_query(packet: AsyncPacket) -> bool:
    """A quadlet write to 0x1800: the broadcast query (only offset bits 15..0 count)."""
    return isinstance(packet, QuadletWriteRequest) and _register_address(packet.offset) == HUB_QUERY


def takes_query(packet: AsyncPacket, firmware: int) -> bool:
    """A broadcast query for a board of ``firmware``: 0x1800, or the old query address."""
    return is_hub_query(packet) or (
        isinstance(packet, QuadletWriteRequest)
        and packet.offset == OLD_QUERY_OFFSET
        and firmware <= OLD_QUERY_LAST_FIRMWARE
    )


def reaches_every_node(packet: AsyncPacket) -> bool:
    """A request every board takes, whichever node it names: broadcast, or one of the
    host's node-0 idioms the boards snoop (a query at 0x1800 or the old query address,
    a block write at the fake-broadcast offset)."""
    if not isinstance(packet, Request):
        return False
    node = packet.destination_node
    if node == BROADCAST_PHY:
        return True
    if node != 0:
        return False
    if isinstance(packet, QuadletWriteRequest):
        return is_hub_query(packet) or packet.offset == OLD_QUERY_OFFSET
    return isinstance(packet, BlockWriteRequest) and packet.offset == FAKE_BROADCAST_OFFSET


def as_snooped(packet: Request) -> Request:
    """``packet`` as a board it does not name takes it: like a broadcast (no ack)."""
    return replace(packet, destination_id=BROADCAST_ID)


def hub_broadcast(board: Qla1Board, node_id: int) -> BlockWriteRequest | None:
    """The block ``board`` broadcasts after a query naming it, or None.

    Data: ``{sequence 31..16, quadlet count 7..0}``, then the real-time block
    the board sampled when the query arrived.
    """
    hub = board.hub
    own = hub.blocks.get(board.board_id)
    if own is None or own.sequence != hub.sequence:
        return None
    first = (hub.sequence & 0xFFFF) << 16 | len(own.quadlets) & 0xFF
    words = (first, *own.quadlets)
    return BlockWriteRequest(
        destination_id=BROADCAST_ID,
        source_id=node_id_of(phy_of(node_id)),
        tlabel=0,
        priority=HUB_BROADCAST_PRIORITY,
        offset=HUB_BROADCAST_OFFSET,
        data=struct.pack(f">{len(words)}I", *words),
    )


def broadcast_sequence(packet: BlockWriteRequest) -> int | None:
    """The query sequence a hub-data broadcast answers, or None if it is not one."""
    if _register_address(packet.offset) != HUB_MEMORY_BASE or len(packet.data) < 4:
        return None
    return int.from_bytes(packet.data[:4], "big") >> 16
