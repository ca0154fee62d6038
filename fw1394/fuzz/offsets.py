"""Destination offsets worth sending: each board's registers and the 1394 boundaries.

A random 48-bit offset almost never hits a register, so requests mostly go
where the board decodes something (derived from the register map its kind
registers, :mod:`fw1394.boards.regmap`), to the CSR and configuration-ROM
space every node has, and to the edges where parsers go wrong: the top of the
address space, the JHU "fake broadcast" offset 0xFFFF_FFFF_0000, and offsets
that alias a register above the 16 bits the thesis and JHU boards decode.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.boards.registry import BOARDS
from fw1394.boards.regmap import RegisterMap

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


def from_map(registers: RegisterMap) -> OffsetModel:
    """The offsets worth sending to a board whose register map is ``registers``.

    Every register, a few elements of each array, the map's spots; the writable
    registers (state a write can damage) are the sweep.
    """
    spots: list[int] = []
    sweep: list[int] = []
    for placed in registers.placed():
        register, step = placed.register, registers.step(placed.group)
        elements = _array_spots(register.count)
        spots += (placed.address + step * n for n in elements)
        if register.access == "rw":
            if register.count == 1:
                sweep.append(placed.address)
            else:
                sweep += (placed.address + step * n for n in _array_sweep(register.count))
    spots += registers.spots
    return OffsetModel(
        tuple(dict.fromkeys(spots)),
        tuple(dict.fromkeys(sweep)),
        probe=registers.offset(registers.probe),
        quadlet_index=registers.quadlet_index,
    )


def _array_spots(count: int) -> tuple[int, ...]:
    # The first few elements, the middle, the last two and one past the end.
    picks = (0, 1, 2, 4, 0x40, 0x200, 0x400, count // 2, count - 2, count - 1, count)
    return tuple(sorted({n for n in picks if 0 <= n <= count})) if count > 1 else (0,)


def _array_sweep(count: int) -> tuple[int, ...]:
    return (*range(min(count, 16)), count // 2, count - 1)


#: Quadlet indices a node nothing is known about is sent most, when it addresses
#: registers by index (a JHU board: its 16 board registers and 4 channels' 16).
GENERIC_INDICES = 0x50


def _generic(quadlet_index: bool) -> OffsetModel:
    """A node nothing is known about, byte addressed or (an Eth1394 board) by index."""
    if quadlet_index:
        spots = tuple(range(GENERIC_INDICES))
        return OffsetModel(spots, spots[:16], probe=0, quadlet_index=True)
    spots = (*range(0, 0x40, 4), 0x100, 0x1000)
    return OffsetModel(spots, spots[:8], probe=0, quadlet_index=False)


def offset_model(kind: str | None, *, quadlet_index: bool = False) -> OffsetModel:
    """The offsets of board ``kind``; ``None``, unknown or unmapped: a generic node,
    addressed by quadlet index if ``quadlet_index`` (the Eth1394 boards), else by byte."""
    entry = BOARDS.get(kind or "")
    if entry is None or entry.registers is None:
        return _generic(quadlet_index)
    return from_map(entry.registers)


def canonical(offset: int) -> int:
    """The register ``offset`` reaches on a board that decodes only its low 16 bits."""
    return offset & ((1 << DECODED_BITS) - 1)


def aliased(offset: int, high: int) -> int:
    """``offset`` with bits above the 16 a JHU board decodes replaced by ``high``."""
    low = offset & ((1 << DECODED_BITS) - 1)
    return (high << DECODED_BITS | low) & OFFSET_MASK


#: Mismatches whose cause lies in what the addressed register does, so a finding of
#: one is kept per register (:func:`region`); the others are the packet's own.
REGIONAL_FIELDS = frozenset({"ack", "rcode", "quadlet_data", "data", "data_length"})


def region(kind: str | None, offset: int | None) -> str:
    """Where ``offset`` lands on a board of ``kind``, to tell root causes apart: the
    register it reaches through the board's decoding (an element of an array is its
    array), ``unmapped`` for an address that holds nothing, ``""`` when there is no
    map to say (no model, or a packet without an offset)."""
    entry = BOARDS.get(kind or "")
    if entry is None or entry.registers is None or offset is None:
        return ""
    registers = entry.registers
    placed = registers.at(registers.decode(offset & OFFSET_MASK))
    return "unmapped" if placed is None else placed.register.name
