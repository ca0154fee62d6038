"""Destination offsets worth sending: each board's registers and the 1394 boundaries.

A random 48-bit offset almost never hits a register, so requests mostly go
where the board decodes something (from its documentation in
``docs/boards/``), to the CSR and configuration-ROM space every node has, and
to the edges where parsers go wrong: the top of the address space, the JHU
"fake broadcast" offset 0xFFFF_FFFF_0000, and offsets that alias a register
above the 16 bits the thesis and JHU boards decode.
"""

from __future__ import annotations

from dataclasses import dataclass

OFFSET_BITS = 48
OFFSET_MASK = (1 << OFFSET_BITS) - 1
CSR_BASE = 0xFFFF_F000_0000
CONFIG_ROM = CSR_BASE + 0x400
#: What the JHU boards decode of an offset: a 16-bit quadlet index.
DECODED_BITS = 16

BOUNDARY_OFFSETS: tuple[int, ...] = (
    0,
    4,
    0xFFFC,
    0xFFFF,
    0x1_0000,  # the first offset that aliases 0 on a 16-bit decoder
    0xFFFF_0000_0000,
    0xFFFF_FFFF_0000,  # JHU "fake broadcast": register 0 of every board
    CSR_BASE,  # STATE_CLEAR
    CSR_BASE + 0x8,  # NODE_IDS
    CSR_BASE + 0x18,  # SPLIT_TIMEOUT_HI
    CSR_BASE + 0x200,  # CYCLE_TIME
    CSR_BASE + 0x21C,  # BUS_MANAGER_ID
    CONFIG_ROM,
    CONFIG_ROM + 0x3FC,  # the last quadlet of the ROM window
    0xFFFF_FFFF_FFFC,
    0xFFFF_FFFF_FFFF,
    0x0001_0000_0000,
    0x7FFF_FFFF_FFFC,
)


@dataclass(frozen=True)
class OffsetModel:
    """Where one kind of node decodes something."""

    #: Offsets of registers or memory worth hitting.
    registers: tuple[int, ...]
    #: Registers re-read after every few cases to catch state damage.
    sweep: tuple[int, ...]
    #: A register whose quadlet read always answers (the liveness probe).
    probe: int
    #: The board reads the low 16 bits as a quadlet index (so higher bits alias).
    quadlet_index: bool


def _qla1() -> OffsetModel:
    board = tuple(range(16))
    channels = tuple(c << 4 | r for c in range(1, 5) for r in range(13))
    hub = (0x1000, 0x1001, 0x1010, 0x1022, 0x1800, 0x1801, 0x1802, 0x1803)
    csr = tuple(CSR_BASE + b for b in (0, 4, 8, 0x18, 0x1C)) + tuple(
        CONFIG_ROM + 4 * i for i in range(0, 32, 3)
    )
    sweep = (0, 1, 2, 3, 6, 11, *(c << 4 | r for c in range(1, 5) for r in (1, 4, 8)))
    return OffsetModel(board + channels + hub + csr, sweep, probe=4, quadlet_index=True)


def _snake2010() -> OffsetModel:
    board = tuple(range(8))
    channels = tuple(c << 4 | r for c in range(1, 8) for r in range(8))
    sweep = (0, 1, 2, 3, *(c << 4 | r for c in range(1, 8) for r in (1, 2, 4)))
    return OffsetModel(board + channels + (0xFF, 0x100), sweep, probe=4, quadlet_index=True)


def _memory(size: int = 0x1_0000) -> OffsetModel:
    spots = (0, 4, 8, 0x10, 0x100, 0x800, 0x1000, size // 2, size - 8, size - 4, size)
    sweep = (*range(0, 0x40, 4), size // 2, size - 4)
    return OffsetModel((*spots, 2, 6, size - 2), sweep, probe=0, quadlet_index=False)


def _generic() -> OffsetModel:
    # A node nothing is known about: small offsets, byte addressed, and the CSRs.
    spots = (*range(0, 0x40, 4), 0x100, 0x1000)
    return OffsetModel(spots, spots[:8], probe=0, quadlet_index=False)


MODELS = {
    "qla1": _qla1(),
    "snake2010": _snake2010(),
    "snake2010-ztheta": _snake2010(),
    "memory": _memory(),
}


def offset_model(kind: str | None) -> OffsetModel:
    """The offsets of board ``kind`` (``None`` or unknown: a generic node)."""
    return MODELS.get(kind or "", _generic())


def aliased(offset: int, high: int) -> int:
    """``offset`` with bits above the 16 a JHU board decodes replaced by ``high``."""
    low = offset & ((1 << DECODED_BITS) - 1)
    return (high << DECODED_BITS | low) & OFFSET_MASK
