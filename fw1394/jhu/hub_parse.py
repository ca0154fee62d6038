"""Hub memory as the JHU host reads it: sizes and parsing per firmware family.

The host decides how to parse the data of a broadcast read from the
firmware of all its boards, never from the data (jhu-eth1394.md §2.10,
BasePort::ReadAllBoardsBroadcast):

* every board Rev 4-6: 16 slots of 17 quadlets, one per board number, read
  in full (272 quadlets); the header's bits 31..16 must equal the 16-bit
  sequence; the block is the 16 quadlets after the header;
* every board Rev 7: 29-quadlet blocks packed in board order, then one
  timing quadlet; bits 31..16 must equal the 16-bit sequence;
* every board Rev 8 on: packed blocks, each as long as its header's bits
  31..24 say, then one timing quadlet; only the sequence's low byte is
  compared, and bit 15 flags a mismatch the firmware saw.

In every family the status quadlet must name the board expected there (and,
before Rev 8, 4 axes); a block whose header or status quadlet is zero ends
the parse: it and every later board count as not read.

This module is the host side; the boards' side is :mod:`fw1394.boards.qla1.hub`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fw1394.boards.qla1 import rt_blocks as rt
from fw1394.errors import UsageError

#: Quadlets per Rev 4-6 slot and per Rev 7 block, header included.
REV4_6_SLOT = 17
REV7_BLOCK = 29
#: Board numbers a Rev 4-6 hub has a slot for.
BOARD_NUMBERS = 16
AXES_SHIFT, AXES = 28, 4
BOARD_ID_SHIFT = 24
SEQUENCE_MISMATCH = 1 << 15


class MixedFirmwareError(UsageError):
    """The boards' firmware is not one broadcast family: the host refuses broadcast."""


@dataclass(frozen=True)
class HubBoard:
    """A board of the broadcast round: its ID and firmware revision."""

    board_id: int
    firmware: int


def family(firmwares: Sequence[int]) -> str:
    """'rev4-6', 'rev7' or 'rev8+' when every firmware is of it; MixedFirmwareError else."""
    names = {_family(firmware) for firmware in firmwares}
    if len(names) != 1 or min(firmwares) < 4:
        raise MixedFirmwareError(
            f"firmware {sorted(set(firmwares))}: the broadcast read needs every board at "
            "4-6, every board at 7, or every board at 8 or later"
        )
    return names.pop()


def _family(firmware: int) -> str:
    if firmware < 7:
        return "rev4-6"
    return "rev7" if firmware == 7 else "rev8+"


def hub_read_quadlets(boards: Sequence[HubBoard]) -> int:
    """How many quadlets the host reads from 0x1000 for ``boards``."""
    name = family([board.firmware for board in boards])
    if name == "rev4-6":
        return BOARD_NUMBERS * REV4_6_SLOT
    if name == "rev7":
        return REV7_BLOCK * len(boards) + 1
    return sum(rt.rt_read_quadlets(board.firmware) + 1 for board in boards) + 1


def split_hub(
    words: Sequence[int], boards: Sequence[HubBoard], sequence: int
) -> dict[int, list[int] | None]:
    """Board ID -> its real-time block from hub memory ``words`` (None: not valid)."""
    return HubPlan.of(boards).split(words, sequence)


@dataclass(frozen=True)
class HubPlan:
    """What :func:`split_hub` works out from the boards alone, once for a loop's run."""

    family: str
    #: (board ID, the block size its header must give (Rev 8+)), in board order.
    boards: tuple[tuple[int, int], ...]
    #: The boards' IDs, in board order.
    board_ids: tuple[int, ...]

    @classmethod
    def of(cls, boards: Sequence[HubBoard]) -> HubPlan:
        ordered = sorted(boards, key=lambda board: board.board_id)
        name = family([board.firmware for board in ordered])
        sizes = tuple(
            (board.board_id, rt.rt_read_quadlets(board.firmware) + 1) for board in ordered
        )
        return cls(name, sizes, tuple(board.board_id for board in ordered))

    def split(self, words: Sequence[int], sequence: int) -> dict[int, list[int] | None]:
        """:func:`split_hub` of ``words`` for these boards."""
        slots = self.family == "rev4-6"
        rev8 = self.family == "rev8+"
        fixed = REV4_6_SLOT if slots else REV7_BLOCK
        low_sequence, full_sequence = sequence & 0xFF, sequence & 0xFFFF
        blocks: dict[int, list[int] | None] = dict.fromkeys(self.board_ids, None)
        total = len(words)
        position = 0
        for board_id, expected in self.boards:
            if slots:
                position = REV4_6_SLOT * board_id
            if position + 2 < total:
                header, status = words[position], words[position + 2]
            else:
                header, status = (words[position] if position < total else 0), 0
            if header == 0 or status == 0:
                break  # "invalid block": nothing after it is read either
            if rev8:
                size = header >> 24
                good = (
                    size == expected
                    and header >> 16 & 0xFF == low_sequence
                    and not header & SEQUENCE_MISMATCH
                )
            else:
                size = fixed
                good = header >> 16 == full_sequence and status >> AXES_SHIFT == AXES
            # A good block is never empty (sizes are 17, 29 or the board's block + 1):
            # it is whole when it ends within the data.
            if good and status >> BOARD_ID_SHIFT & 0xF == board_id and position + size <= total:
                blocks[board_id] = list(words[position + 1 : position + size])
            position += size or 1
        return blocks
