"""Flat bit-field tables read out of ``construct`` structs.

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
class FlatField:
    """``width`` bits ending at bit ``lsb`` of the big-endian unit at ``byte_offset``."""

    name: str
    byte_offset: int
    byte_size: int
    msb: int
    width: int

    @property
    def lsb(self) -> int:
        return self.msb - self.width + 1

    @property
    def mask(self) -> int:
        return (1 << self.width) - 1


def _is_bit_struct(subcon: Any) -> bool:
    return isinstance(subcon, construct.Transformed) and isinstance(subcon.subcon, construct.Struct)


def flatten(struct: construct.Struct, prefix: str = "") -> list[FlatField]:
    """Every field of ``struct`` in wire order; bit fields get ``parent.child`` names."""
    return list(_walk(struct, prefix))


def _walk(struct: construct.Struct, prefix: str) -> Iterator[FlatField]:
    offset = 0
    for renamed in struct.subcons:
        subcon = renamed.subcon
        name = prefix + renamed.name
        size = subcon.sizeof()
        if _is_bit_struct(subcon):
            msb = 8 * size - 1
            for bit in subcon.subcon.subcons:
                width = bit.subcon.sizeof()
                yield FlatField(f"{name}.{bit.name}", offset, size, msb, width)
                msb -= width
        elif isinstance(subcon, construct.Struct):
            for inner in _walk(subcon, f"{name}."):
                yield FlatField(
                    inner.name, offset + inner.byte_offset, inner.byte_size, inner.msb, inner.width
                )
        else:
            yield FlatField(name, offset, size, 8 * size - 1, 8 * size)
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
