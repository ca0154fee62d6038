"""Hub space: the broadcast query at 0x1800 and the hub memory at 0x1000.

A quadlet write of ``(sequence << 16) | board_mask`` to 0x1800 starts a
"broadcast read": every board in the mask samples its real-time block and
broadcasts it; the hub collects the blocks so the host can fetch them all
with one block read of 0x1000 (or, in Ethernet-only mode, receive them
unasked). Hub memory holds, for each board in board-ID order,
a header quadlet (block size including the header in 31..24, low byte of
the sequence in 23..16, bit 15 set on a sequence mismatch, update time in
14..0) and the block, plus one closing quadlet ({16-bit time of the last
update, 16-bit time of the read}, 49.152 MHz ticks since the query) once
every board in the mask has reported.

The meaning of 0x1801..0x1803 is only named in the reference notes; the
exact packing used here (see :meth:`HubState.read_register`) is this
model's choice.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace

from fw1394.boards.qla1.regs import (
    HUB_BOARD_INFO,
    HUB_LAST_WRITE,
    HUB_MEMORY_BASE,
    HUB_MEMORY_QUADLETS,
    HUB_QUADLETS_WRITTEN,
    HUB_QUERY,
)
from fw1394.boards.qla1.rt_blocks import STATUS

UPDATE_TIME_MASK = 0x7FFF
SEQUENCE_MISMATCH = 1 << 15
#: Board id sits in bits 27..24 of the status quadlet of a real-time block.
STATUS_BOARD_ID_SHIFT = 24


@dataclass(frozen=True)
class HubBlock:
    """One board's real-time block as the hub stored it."""

    sequence: int
    update_ticks: int
    quadlets: tuple[int, ...]

    def header(self, current_sequence: int) -> int:
        mismatch = SEQUENCE_MISMATCH if self.sequence != current_sequence else 0
        size = (len(self.quadlets) + 1) & 0xFF
        return (
            size << 24
            | (self.sequence & 0xFF) << 16
            | mismatch
            | min(self.update_ticks, UPDATE_TIME_MASK)
        )


def reporting_board(block: Sequence[int]) -> int:
    """Whose real-time block this is: the board ID in its status quadlet."""
    return (block[STATUS] >> STATUS_BOARD_ID_SHIFT) & 0xF


def _saturate16(ticks: int) -> int:
    return min(max(ticks, 0), 0xFFFF)


@dataclass
class HubState:
    """Query registers and collected blocks of one board's hub."""

    board_id: int
    sequence: int = 0
    board_mask: int = 0
    query_tick: int = 0
    blocks: dict[int, HubBlock] = field(default_factory=dict)
    last_update_tick: int = 0

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
        self.keep(board_id, HubBlock(sequence, now - self.query_tick, tuple(quadlets)), now)

    def keep(self, board_id: int, block: HubBlock, now: int) -> None:
        """:meth:`store` of a block made already (blocks are frozen: hubs can share one)."""
        update_ticks = now - self.query_tick
        if block.update_ticks != update_ticks:
            block = replace(block, update_ticks=update_ticks)
        self.blocks.pop(board_id, None)
        self.blocks[board_id] = block
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
        memory: list[int] = []
        # Each board's block has a fixed slot, after those of the lower-numbered
        # boards of the mask (hence 0x1803's lower-board mask): board order, not
        # arrival order, which is also the order the host parses.
        for _, block in sorted(self.blocks.items()):
            memory.append(block.header(self.sequence))
            memory.extend(block.quadlets)
        if self.complete:
            last_update = _saturate16(self.last_update_tick - self.query_tick)
            memory.append(last_update << 16 | _saturate16(now - self.query_tick))
        return memory[:HUB_MEMORY_QUADLETS]

    def read_register(self, index: int, now: int) -> int:
        """Quadlet at hub-space ``index`` (0x1000..0x1FFF); 0 where nothing is mapped."""
        if index == HUB_QUERY:
            return self.sequence << 16 | self.board_mask
        written = sum(len(block.quadlets) + 1 for block in self.blocks.values())
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
