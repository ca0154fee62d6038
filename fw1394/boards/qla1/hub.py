"""Hub space: the broadcast query at 0x1800 and the hub memory at 0x1000.

A quadlet write of ``(sequence << 16) | board_mask`` to 0x1800 starts a
"broadcast read": every board in the mask samples its real-time block and
broadcasts it; the hub collects the blocks so the host can fetch them all
with one block read of 0x1000 (or, in Ethernet-only mode, receive them
unasked).

How the blocks lie in hub memory depends on the hub's firmware revision
(jhu-eth1394.md §2.10), and the host parses them by the revision of all its
boards; :class:`HubLayout` holds the three families as data:

* Rev 4-6: a 17-quadlet slot for every board number 0-15 (slot index = board
  number; slots of boards not in the round stay zero): the full 16-bit
  sequence in bits 31..16 of the header, then the first 16 quadlets of the
  board's real-time block; no update time and no closing quadlet;
* Rev 7: packed 29-quadlet blocks in board order: header = full 16-bit
  sequence in 31..16 and the update time (14 bits) in 15..0, then the
  28-quadlet Rev 7 block;
* Rev 8 on: packed blocks in board order, header = block size including the
  header in 31..24, low byte of the sequence in 23..16, bit 15 set on a
  sequence mismatch, update time in 14..0 (14 bits before firmware 9, 15
  from 9).

Rev 7 and Rev 8+ end with one closing quadlet ({time of the last update,
time of the read}, 49.152 MHz ticks since the query, 14 bits each before
firmware 9, 16 from 9) once every board in the mask has reported. Times
wrap at their width, as the firmware's counters do (the host detects the
wrap). In a rack of mixed firmware the layout is the hub board's: the host
only uses the broadcast read when every board is of one family.

The meaning of 0x1801..0x1803 is only named in the reference notes; the
exact packing used here (see :meth:`HubState.read_register`) is this
model's choice.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import NamedTuple

from fw1394.boards.qla1.regs import (
    HUB_BOARD_INFO,
    HUB_LAST_WRITE,
    HUB_MEMORY_BASE,
    HUB_MEMORY_QUADLETS,
    HUB_QUADLETS_WRITTEN,
    HUB_QUERY,
)
from fw1394.boards.qla1.rt_blocks import STATUS

SEQUENCE_MISMATCH = 1 << 15
#: Board id sits in bits 27..24 of the status quadlet of a real-time block.
STATUS_BOARD_ID_SHIFT = 24
#: Board numbers a Rev 4-6 hub keeps a slot for.
BOARD_NUMBERS = 16
#: The first firmware with wider hub timers (15-bit update, 16-bit closing times).
WIDE_TIMER_FIRMWARE = 9


class HubBlock(NamedTuple):
    """One board's real-time block as the hub stored it (a tuple: immutable, so hubs can
    share one, and cheap to make, as every board stores one every cycle)."""

    sequence: int
    update_ticks: int
    quadlets: tuple[int, ...]


@dataclass(frozen=True)
class HubLayout:
    """Where a firmware family puts each board's block in hub memory."""

    family: str
    #: Every board number 0-15 has its slot, in use or not (Rev 4-6); else packed.
    slot_per_board_number: bool
    #: Data quadlets a block keeps (16 for Rev 4-6, 28 for Rev 7); None: its own size.
    data_quadlets: int | None
    #: Header carries the full 16-bit sequence (Rev 4-7) or its low byte, the block
    #: size and the mismatch bit (Rev 8+).
    full_sequence: bool
    #: Width of the update time in the header (0: none).
    update_time_bits: int
    #: Width of each half of the closing timing quadlet (0: no closing quadlet).
    timing_bits: int

    def words(self, blocks: Iterable[HubBlock], current_sequence: int) -> list[int]:
        """Each of ``blocks`` as hub memory holds it, in turn: its header, then its data.

        ``current_sequence``: the hub's query sequence (a Rev 8+ header flags a block
        of another). One loop for every block, not a call per block: the hub lays
        out the whole round every cycle.
        """
        update_mask = (1 << self.update_time_bits) - 1
        full_sequence, kept = self.full_sequence, self.data_quadlets
        memory: list[int] = []
        for sequence, update_ticks, quadlets in blocks:
            if full_sequence:
                memory.append((sequence & 0xFFFF) << 16 | update_ticks & update_mask)
            else:
                size = (len(quadlets) + 1) & 0xFF
                mismatch = SEQUENCE_MISMATCH if sequence != current_sequence else 0
                memory.append(
                    size << 24 | (sequence & 0xFF) << 16 | mismatch | update_ticks & update_mask
                )
            if kept is None:
                memory += quadlets
            else:
                memory += quadlets[:kept]
                memory += (0,) * (kept - len(quadlets))
        return memory

    def data(self, block: HubBlock) -> tuple[int, ...]:
        if self.data_quadlets is None:
            return block.quadlets
        kept = block.quadlets[: self.data_quadlets]
        return kept + (0,) * (self.data_quadlets - len(kept))

    def timing(self, last_update_ticks: int, read_ticks: int) -> int:
        mask = (1 << self.timing_bits) - 1
        return (last_update_ticks & mask) << 16 | read_ticks & mask


def hub_layout(firmware: int) -> HubLayout:
    """The hub memory layout of a board running ``firmware``."""
    if firmware < 7:
        return HubLayout("rev4-6", True, 16, True, 0, 0)
    if firmware == 7:
        return HubLayout("rev7", False, 28, True, 14, 14)
    wide = firmware >= WIDE_TIMER_FIRMWARE
    return HubLayout("rev8+", False, None, False, 15 if wide else 14, 16 if wide else 14)


def reporting_board(block: Sequence[int]) -> int:
    """Whose real-time block this is: the board ID in its status quadlet."""
    return (block[STATUS] >> STATUS_BOARD_ID_SHIFT) & 0xF


@dataclass
class HubState:
    """Query registers and collected blocks of one board's hub."""

    board_id: int
    firmware: int = 8
    sequence: int = 0
    board_mask: int = 0
    query_tick: int = 0
    blocks: dict[int, HubBlock] = field(default_factory=dict)
    last_update_tick: int = 0

    def __post_init__(self) -> None:
        self.layout = hub_layout(self.firmware)

    def query(self, value: int, now: int) -> None:
        """A write to 0x1800: new sequence and mask, forget the previous round."""
        self.sequence = value >> 16
        self.board_mask = value & 0xFFFF
        self.query_tick = now
        self.blocks.clear()

    def wants(self, board_id: int) -> bool:
        return bool(self.board_mask >> board_id & 1)

    def store(self, board_id: int, sequence: int, quadlets: Sequence[int], now: int) -> None:
        """Keep ``board_id``'s block; a newer block from the same board replaces it."""
        blocks = self.blocks
        if board_id in blocks:
            del blocks[board_id]  # a newer block goes last, as a broadcast would
        blocks[board_id] = HubBlock(sequence, now - self.query_tick, tuple(quadlets))
        self.last_update_tick = now

    def keep(self, board_id: int, block: HubBlock, now: int) -> None:
        """:meth:`store` of a block made already (blocks are frozen: hubs can share one)."""
        update_ticks = now - self.query_tick
        if block.update_ticks != update_ticks:
            block = block._replace(update_ticks=update_ticks)
        blocks = self.blocks
        if board_id in blocks:
            del blocks[board_id]  # a newer block goes last, as a broadcast would
        blocks[board_id] = block
        self.last_update_tick = now

    def keep_all(self, blocks: Sequence[tuple[int, HubBlock]], now: int) -> None:
        """:meth:`keep` of every (board ID, block) of ``blocks`` in turn."""
        update_ticks = now - self.query_tick
        stored = self.blocks
        for board_id, block in blocks:
            if block.update_ticks != update_ticks:
                block = block._replace(update_ticks=update_ticks)
            if board_id in stored:
                del stored[board_id]  # a newer block goes last, as a broadcast would
            stored[board_id] = block
        if blocks:
            self.last_update_tick = now

    def keep_round(self, round_blocks: Mapping[int, HubBlock], now: int) -> None:
        """:meth:`keep_all` of a whole round at once, for a rack that serves every board.

        ``round_blocks``: every board's block of the round, keyed by its reporting
        board, in the order the broadcasts come; this hub's own block is among them,
        the same object it stored at the query. Taken at the tick of this hub's query,
        with every block made at its own board's query tick (both update times 0), and
        with no key but its own in :attr:`blocks` yet: then keeping the others in turn
        is one dict update (the own block keeps its place, first).
        """
        self.blocks.update(round_blocks)
        self.last_update_tick = now

    def store_broadcast(self, words: Sequence[int], now: int) -> None:
        """A board's broadcast: {sequence 31..16, quadlet count 7..0}, then its block."""
        if len(words) < 1 + STATUS + 1:
            return  # too short to say whose block it is
        count = words[0] & 0xFF
        block = words[1 : 1 + count]
        if len(block) <= STATUS:
            return
        self.store(reporting_board(block), words[0] >> 16, block, now)

    @property
    def complete(self) -> bool:
        """True once every board of the mask has reported in this round."""
        reported = 0
        for board_id in self.blocks:
            reported |= 1 << board_id
        return bool(self.board_mask) and self.board_mask & ~reported == 0

    def image(self, now: int) -> list[int]:
        """Hub memory as the host reads it from 0x1000."""
        layout = self.layout
        memory: list[int] = []
        if layout.slot_per_board_number:
            assert layout.data_quadlets is not None
            slot = layout.data_quadlets + 1
            memory = [0] * (slot * BOARD_NUMBERS)
            for board_id, block in self.blocks.items():
                start = slot * board_id
                memory[start : start + slot] = layout.words([block], self.sequence)
            return memory[:HUB_MEMORY_QUADLETS]
        # Each board's block has a fixed slot, after those of the lower-numbered
        # boards of the mask (hence 0x1803's lower-board mask): board order, not
        # arrival order, which is also the order the host parses.
        blocks = self.blocks
        memory = layout.words([blocks[board_id] for board_id in sorted(blocks)], self.sequence)
        if self.complete and layout.timing_bits:
            last_update = max(self.last_update_tick - self.query_tick, 0)
            memory.append(layout.timing(last_update, max(now - self.query_tick, 0)))
        return memory[:HUB_MEMORY_QUADLETS]

    def read_registers(self, indices: Sequence[int], now: int) -> list[int]:
        """:meth:`read_register` of each of ``indices`` (a block read), hub memory laid
        out once."""
        memory: list[int] | None = None
        words = []
        for index in indices:
            position = index - HUB_MEMORY_BASE
            if 0 <= position < HUB_MEMORY_QUADLETS:
                if memory is None:
                    memory = self.image(now)
                words.append(memory[position] if position < len(memory) else 0)
            else:
                words.append(self.read_register(index, now))
        return words

    def read_run(self, first: int, count: int, now: int) -> list[int]:
        """:meth:`read_registers` of ``first``, ``first + 1``, ... ``count`` indices: a
        run inside hub memory is one slice of it (the host's read of 0x1000)."""
        start = first - HUB_MEMORY_BASE
        if start < 0 or start + count > HUB_MEMORY_QUADLETS:
            return self.read_registers(range(first, first + count), now)
        words = self.image(now)[start : start + count]
        return words + [0] * (count - len(words))

    def read_register(self, index: int, now: int) -> int:
        """Quadlet at hub-space ``index`` (0x1000..0x1FFF); 0 where nothing is mapped."""
        if index == HUB_QUERY:
            return self.sequence << 16 | self.board_mask
        written = sum(len(self.layout.data(block)) + 1 for block in self.blocks.values())
        if index == HUB_LAST_WRITE:
            # {index of the last quadlet written, quadlets in use}
            return max(written - 1, 0) << 16 | written
        if index == HUB_QUADLETS_WRITTEN:
            return written
        if index == HUB_BOARD_INFO:
            lower_boards = self.board_mask & ((1 << self.board_id) - 1)
            return self.board_id << 16 | lower_boards
        position = index - HUB_MEMORY_BASE
        if 0 <= position < HUB_MEMORY_QUADLETS:
            memory = self.image(now)
            return memory[position] if position < len(memory) else 0
        return 0
