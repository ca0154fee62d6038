"""Fast paths: header tuples for bulk decoding, whole packets for the bus.

The header code here is generated from the layouts in
:mod:`fw1394.packets.layouts` (see :class:`fw1394.packets.fields.Quadlets`);
tests hold every function equal to the general codec with hypothesis.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from typing import Any

from fw1394.crc import crc32, padded
from fw1394.packets.asynchronous import ASYNC_CLASSES, AsyncPacket, decode_async, encode_async
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


# -- whole packets, for the bus's hot path ---------------------------------------------
_QUADLET = struct.Struct(">I")
_HEADER_PACKERS: dict[type[AsyncPacket], Callable[[Any], bytes | None]] = {
    cls: cls.LAYOUT.header.attribute_packer({"tcode": int(tcode)})
    for tcode, cls in ASYNC_CLASSES.items()
}
_CLASSES: dict[int, type[AsyncPacket]] = {int(t): c for t, c in ASYNC_CLASSES.items()}


def encode_packet(packet: AsyncPacket) -> bytes:
    """The same bytes as :func:`fw1394.packets.encode`, faster for ordinary packets.

    Packets the engine emits (no CRCs given, ``data_length`` equal to the data's
    length, nothing trailing) are packed by code generated from the layouts; any
    other packet goes through the general codec.
    """
    data: bytes | None = getattr(packet, "data", None)
    if (
        packet.header_crc is not None
        or packet.trailing
        or (data is not None and (packet.data_crc is not None or len(data) != packet.data_length))  # type: ignore[attr-defined]
    ):
        return encode_async(packet)
    header = _HEADER_PACKERS[type(packet)](packet)
    if header is None:
        return encode_async(packet)  # a field out of range: the codec names it
    wire = header + _QUADLET.pack(crc32(header))
    if data is None:
        return wire
    block = padded(data)
    return wire + block + _QUADLET.pack(crc32(block))


def _factory(cls: type[AsyncPacket]) -> Callable[..., AsyncPacket]:
    """``make(values, data, data_crc)``: a packet from header values in layout order.

    Generated so that decoding sets each slot directly instead of going through
    the frozen dataclass ``__init__`` (which costs as much as the rest of the
    decode); values come from a sound packet, so there is nothing to validate.
    """
    names = FIELD_NAMES[int(cls.LAYOUT.tcode)]
    namespace: dict[str, Any] = {"new": object.__new__, "cls": cls}
    lines = ["def make(values, data, data_crc):", "    packet = new(cls)"]
    unpacked = ", ".join(name if name != "tcode" else "_" for name in names)
    lines.append(f"    {unpacked}, = values")
    stored = [*(n for n in names if n != "tcode"), "trailing"]
    if cls.LAYOUT.has_data:
        stored += ["data", "data_crc"]
    for name in stored:
        namespace[f"set_{name}"] = getattr(cls, name).__set__
        value = 'b""' if name == "trailing" else name
        lines.append(f"    set_{name}(packet, {value})")
    lines.append("    return packet")
    exec("\n".join(lines) + "\n", namespace)
    make: Callable[..., AsyncPacket] = namespace["make"]
    return make


_FACTORIES: dict[int, Callable[..., AsyncPacket]] = {
    tcode: _factory(cls) for tcode, cls in _CLASSES.items()
}


def decode_sound(raw: bytes) -> AsyncPacket | None:
    """The packet if ``raw`` is a sound asynchronous packet (no ``problems``), else None.

    Equal to ``decode_async(raw, strict=True)`` where that succeeds; decoded with
    the generated header decoders, for the bus's receive path.
    """
    tcode = raw[TCODE_BYTE] >> TCODE_SHIFT if len(raw) >= 4 else -1
    size = HEADER_SIZES.get(tcode, 0)
    if (
        not size
        or len(raw) < size
        or crc32(raw[: size - 4]) != int.from_bytes(raw[size - 4 : size])
    ):
        return None
    values = _DECODERS[tcode](raw)
    if not _CLASSES[tcode].LAYOUT.has_data:
        return _FACTORIES[tcode](values, None, None) if len(raw) == size else None
    length = values[FIELD_NAMES[tcode].index("data_length")]
    end = size + length + (-length % 4)
    data_crc = int.from_bytes(raw[end:])
    if len(raw) != end + 4 or data_crc != crc32(raw[size:end]):
        return None
    return _FACTORIES[tcode](values, raw[size : size + length], data_crc)


def decode_packet(raw: bytes) -> AsyncPacket:
    """The same packet as ``decode_async(raw)`` (lenient), faster for sound packets."""
    packet = decode_sound(raw)
    return decode_async(raw) if packet is None else packet
