"""Bulk header decoding for captures: tuples of field values, no objects.

Everything here is generated from the layouts in :mod:`fw1394.packets.layouts`
(see :meth:`fw1394.packets.fields.Quadlets.unpack_values`); tests check it
against :func:`fw1394.packets.decode` with hypothesis.
"""

from __future__ import annotations

from collections.abc import Callable

from fw1394.packets.layouts import LAYOUTS, TCODE_BYTE, TCODE_SHIFT

#: tcode -> field names of the values :func:`decode_header` returns for it.
FIELD_NAMES: dict[int, tuple[str, ...]] = {
    int(tcode): layout.sealed_header.names for tcode, layout in LAYOUTS.items()
}
#: tcode -> bytes of header including the header CRC.
HEADER_SIZES: dict[int, int] = {
    int(tcode): 4 * layout.sealed_header.count for tcode, layout in LAYOUTS.items()
}
_DECODERS: dict[int, Callable[..., tuple[int, ...]]] = {
    int(tcode): layout.sealed_header.unpack_values for tcode, layout in LAYOUTS.items()
}


def decode_header(buffer: bytes, offset: int = 0) -> tuple[int, ...]:
    """Header field values (with header CRC) of the packet at ``buffer[offset:]``.

    The order is ``FIELD_NAMES[tcode]``. Raises ``KeyError`` for a tcode with no
    layout and ``struct.error`` for a buffer too short for the header; callers
    in bulk loops check :data:`HEADER_SIZES` first.
    """
    return _DECODERS[buffer[offset + TCODE_BYTE] >> TCODE_SHIFT](buffer, offset)
