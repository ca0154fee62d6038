"""One-field readers generated from the packet layouts, for code that needs one field fast.

Trace readers, the capture analysis and the bus members often want a single
header field (the tcode to pick a layout, the source ID to name the sender)
without decoding the packet. Each :class:`FieldReader` is generated from the
field's place in a :class:`~fw1394.packets.fields.Quadlets` layout, so no
module outside :mod:`fw1394.packets` writes a header shift by hand.

:data:`ASYNC` holds the fields that sit in the same bits in every asynchronous
layout that has them (the tcode, both node IDs, the tlabel, the rcode, the
48-bit offset...); :func:`layout_reader` gives any field of one layout.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

from fw1394.packets.codegen import compile_function
from fw1394.packets.enums import TCode
from fw1394.packets.fields import BitField, Quadlets
from fw1394.packets.layouts import LAYOUTS
from fw1394.packets.phy import PLAIN_EXTENDED, SELF_ID_ZERO

Buffer = bytes | bytearray | memoryview


@dataclass(frozen=True)
class FieldReader:
    """Reads one logical field, from wire bytes or from header quadlet values."""

    name: str
    parts: tuple[BitField, ...]
    #: ``of_bytes(data, offset=0)``: the field of the packet starting at ``data[offset]``.
    of_bytes: Callable[..., int] = field(init=False, repr=False, compare=False)
    #: ``of_quadlets(quadlets)``: the field from a sequence of header quadlet values.
    of_quadlets: Callable[[Sequence[int]], int] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        namespace: dict[str, Any] = {"from_bytes": int.from_bytes}
        origin = f"fw1394.packets.accessors {self.name}"
        of_bytes = compile_function(self._bytes_source(), namespace, "of_bytes", origin=origin)
        of_quadlets = compile_function(
            self._quadlets_source(), namespace, "of_quadlets", origin=origin
        )
        object.__setattr__(self, "of_bytes", of_bytes)
        object.__setattr__(self, "of_quadlets", of_quadlets)

    @property
    def quadlet(self) -> int:
        """The quadlet of a field that lives in one (``ValueError`` for a split field)."""
        return self._single().quadlet

    @property
    def shift(self) -> int:
        """Right shift that brings a one-quadlet field to bit 0 of its quadlet."""
        return self._single().lsb

    @property
    def mask(self) -> int:
        """Mask of a one-quadlet field after :attr:`shift`."""
        return self._single().mask

    @property
    def end(self) -> int:
        """Bytes a packet needs for this field to be readable."""
        return max(first + size for first, size, _ in map(_byte_span, self.parts))

    @property
    def byte_span(self) -> tuple[int, int, int]:
        """(first byte, byte count, right shift) of the bytes a one-quadlet field touches."""
        return _byte_span(self._single())

    def _single(self) -> BitField:
        if len(self.parts) != 1:
            raise ValueError(f"{self.name} is split over {len(self.parts)} quadlets")
        return self.parts[0]

    def __call__(self, quadlets: Sequence[int]) -> int:
        return self.of_quadlets(quadlets)

    def _bytes_source(self) -> str:
        # Read only the bytes the field touches: one indexing for a field inside a byte.
        terms = []
        for part in self.parts:
            first, size, shift = _byte_span(part)
            if size == 1:
                term = f"data[offset + {first}]"
            else:
                term = f"from_bytes(data[offset + {first}:offset + {first + size}], 'big')"
            terms.append(_shaped(term, shift, part, 8 * size))
        return f"def of_bytes(data, offset=0):\n    return {' | '.join(terms)}\n"

    def _quadlets_source(self) -> str:
        terms = [_shaped(f"quadlets[{p.quadlet}]", p.lsb, p, 32) for p in self.parts]
        return f"def of_quadlets(quadlets):\n    return {' | '.join(terms)}\n"


def _byte_span(part: BitField) -> tuple[int, int, int]:
    first = 4 * part.quadlet + (31 - part.msb) // 8
    last = 4 * part.quadlet + (31 - part.lsb) // 8
    return first, last - first + 1, part.lsb - 8 * (3 - (31 - part.lsb) // 8)


def _shaped(term: str, shift: int, part: BitField, bits: int) -> str:
    if shift:
        term = f"({term} >> {shift})"
    if part.width + shift < bits:
        term = f"({term} & {part.mask:#x})"
    if part.shift:
        term = f"({term} << {part.shift})"
    return term


def readers(layout: Quadlets) -> dict[str, FieldReader]:
    """A reader for every field of one layout (``reserved`` bits left out)."""
    parts: dict[str, list[BitField]] = {}
    for bitfield in layout.bitfields:
        if bitfield.name != "reserved":
            parts.setdefault(bitfield.name, []).append(bitfield)
    return {name: FieldReader(name, tuple(found)) for name, found in parts.items()}


def common_readers(layouts: Iterable[Quadlets]) -> dict[str, FieldReader]:
    """Readers of the fields that sit in the same bits in every layout that has them."""
    seen: dict[str, set[tuple[BitField, ...]]] = {}
    for layout in layouts:
        for name, reader in readers(layout).items():
            seen.setdefault(name, set()).add(reader.parts)
    return {
        name: FieldReader(name, next(iter(places)))
        for name, places in seen.items()
        if len(places) == 1
    }


def layout_reader(tcode: int, name: str) -> FieldReader:
    """The reader of field ``name`` in the layout of ``tcode`` (``KeyError`` if it has none)."""
    return _LAYOUT_READERS[TCode(tcode)][name]


_LAYOUT_READERS = {tcode: readers(layout.sealed_header) for tcode, layout in LAYOUTS.items()}
#: Fields placed alike in every asynchronous layout that has them.
ASYNC = common_readers(layout.sealed_header for layout in LAYOUTS.values())
TCODE = ASYNC["tcode"]
TLABEL = ASYNC["tlabel"]
DESTINATION_ID = ASYNC["destination_id"]
SOURCE_ID = ASYNC["source_id"]
RCODE = ASYNC["rcode"]
OFFSET = ASYNC["offset"]
#: Fields of self-ID packet #0 (the identifier and phy_id sit alike in every PHY packet
#: that has them).
SELF_ID = readers(Quadlets(SELF_ID_ZERO))
PHY_IDENTIFIER = SELF_ID["identifier"]
SELF_ID_PHY = SELF_ID["phy_id"]
#: The bits that tell PHY packet kinds apart, most significant first: the identifier,
#: bits 23-22 (R and T of identifier 0, the extended bit of self-IDs) and the 1394a type.
PHY_KIND_BITS: tuple[FieldReader, ...] = tuple(
    readers(Quadlets(PLAIN_EXTENDED))[name]
    for name in ("identifier", "force_root", "gap_count_optimization", "type")
)

__all__ = [
    "ASYNC",
    "DESTINATION_ID",
    "OFFSET",
    "PHY_IDENTIFIER",
    "PHY_KIND_BITS",
    "RCODE",
    "SELF_ID",
    "SELF_ID_PHY",
    "SOURCE_ID",
    "TCODE",
    "TLABEL",
    "FieldReader",
    "common_readers",
    "layout_reader",
    "readers",
]
