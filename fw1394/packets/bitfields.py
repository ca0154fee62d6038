"""Bit fields: the one description of where a field sits, and tables of them.

:class:`BitField` places a field in a header; the quadlet layouts of
:class:`fw1394.packets.fields.Quadlets` and the flat tables read out of
``construct`` structs here are both lists of it.

The dissector generators (Lua, scapy), the numpy decoders and the virtual
bus's frame header need to know where each field sits; they read it from the
one ``construct`` definition of a header instead of repeating it. Only the
building blocks the framing structs use are understood: byte-level integers
(plain, ``Const`` or ``Default``) and ``BitStruct`` bytes.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import construct


@dataclass(frozen=True)
class BitField:
    """``width`` bits, most significant bit ``msb``, of the big-endian unit at ``byte_offset``.

    The unit is ``byte_size`` bytes (a quadlet in 1394 headers). ``shift``
    places the bits inside a logical field split across units: the 48-bit
    offset is its top 16 bits at shift 32 in one quadlet, the rest in the next.
    """

    name: str
    byte_offset: int
    byte_size: int
    msb: int
    width: int
    shift: int = 0

    @property
    def quadlet(self) -> int:
        """Index of the quadlet that holds the field (for quadlet-sized units)."""
        return self.byte_offset // 4

    @property
    def lsb(self) -> int:
        return self.msb - self.width + 1

    @property
    def mask(self) -> int:
        return (1 << self.width) - 1


def _is_bit_struct(subcon: Any) -> bool:
    return isinstance(subcon, construct.Transformed) and isinstance(subcon.subcon, construct.Struct)


def flatten(struct: construct.Struct, prefix: str = "") -> list[BitField]:
    """Every field of ``struct`` in wire order; bit fields get ``parent.child`` names."""
    return list(_walk(struct, prefix))


def _walk(struct: construct.Struct, prefix: str) -> Iterator[BitField]:
    offset = 0
    for renamed in struct.subcons:
        subcon = renamed.subcon
        name = prefix + renamed.name
        size = subcon.sizeof()
        if _is_bit_struct(subcon):
            msb = 8 * size - 1
            for bit in subcon.subcon.subcons:
                width = bit.subcon.sizeof()
                yield BitField(f"{name}.{bit.name}", offset, size, msb, width)
                msb -= width
        elif isinstance(subcon, construct.Struct):
            for inner in _walk(subcon, f"{name}."):
                yield BitField(
                    inner.name, offset + inner.byte_offset, inner.byte_size, inner.msb, inner.width
                )
        else:
            yield BitField(name, offset, size, 8 * size - 1, 8 * size)
        offset += size


def struct_format(struct: construct.Struct, skip: frozenset[str] = frozenset()) -> str:
    """A big-endian :mod:`struct` format with one integer per byte-level unit.

    Units named in ``skip`` become pad bytes, so unpacking yields only the others.
    """
    codes = {1: "B", 2: "H", 4: "I", 8: "Q"}
    units: dict[int, tuple[int, str]] = {}
    for field in flatten(struct):
        units[field.byte_offset] = (field.byte_size, field.name)
    parts = []
    for offset in sorted(units):
        size, name = units[offset]
        parts.append(f"{size}x" if name in skip else codes[size])
    return ">" + "".join(parts)
