"""Fast paths: header tuples for bulk decoding, whole packets for the bus.

Everything here is generated from the layouts in :mod:`fw1394.packets.layouts`
(see :class:`fw1394.packets.fields.Quadlets`) and the packet classes; tests hold
every function equal to the general codec with hypothesis.

The bus runs :func:`encode_packet` and :func:`decode_sound` for every packet,
so each kind gets one straight-line function that does the whole packet (header,
CRCs, data block) and sets the frozen dataclass's slots directly: going through
the dataclass ``__init__`` or the construct structs costs more than the rest of
a transaction.
"""

from __future__ import annotations

import re
import struct
import zlib
from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any, TypeVar

from fw1394.crc import CHECK_VALUE, crc32
from fw1394.packets.asynchronous import ASYNC_CLASSES, AsyncPacket, decode_async, encode_async
from fw1394.packets.codegen import compile_function
from fw1394.packets.layouts import LAYOUTS, TCODE_BYTE, TCODE_SHIFT

P = TypeVar("P", bound=AsyncPacket)

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


# -- CRC of data blocks ----------------------------------------------------------------
#: Bytes with their bit order reversed.
_REVERSED = bytes(int(f"{byte:08b}"[::-1], 2) for byte in range(256))
#: From this length on zlib's CRC (below) is faster than crcmod's byte-wise table.
_ZLIB_FROM = 256


def _crc32_by_zlib(data: bytes) -> int:
    # The 1394 CRC (CRC-32/BZIP2) and zlib's CRC-32 share polynomial, initial
    # value and final complement, but zlib's reflects bits: on bit-reversed bytes
    # it computes the bit-reversed 1394 CRC. zlib runs several times faster than
    # crcmod, which pays off beyond the reversal's cost on data blocks (a 2 KB
    # block read response: 2.5 us instead of 7).
    reflected = zlib.crc32(data.translate(_REVERSED))
    return int.from_bytes(reflected.to_bytes(4, "little").translate(_REVERSED))


def block_crc(data: bytes) -> int:
    """:func:`fw1394.crc.crc32` of ``data``, the fastest way for its length."""
    return crc32(data) if len(data) < _ZLIB_FROM else _crc32_by_zlib(data)


if _crc32_by_zlib(b"123456789") != CHECK_VALUE:  # pragma: no cover - a broken zlib
    _ZLIB_FROM = 1 << 62


def data_block_source(header_size: int, data_length: str) -> list[str]:
    """Generated lines that take a block packet's data block from ``raw``.

    ``data_length`` is the expression of the header's length field. The lines
    return None from the generated function when the packet is not exactly
    header, padded data and data CRC, or the CRC is wrong; else they leave the
    data (padding cut off) in ``data``. The function's namespace needs
    ``block_crc`` and ``from_bytes`` (``int.from_bytes``).
    """
    return [
        f"    data_length = {data_length}",
        f"    end = {header_size} + data_length + (-data_length & 3)",
        "    if len(raw) != end + 4:",
        "        return None",
        f"    data = raw[{header_size}:end]",
        "    if from_bytes(raw[end:]) != block_crc(data):",
        "        return None",
        f"    if end != {header_size} + data_length:",
        "        data = data[:data_length]",
    ]


# -- whole packets, for the bus's hot path ---------------------------------------------
_QUADLET = struct.Struct(">I")
_CLASSES: dict[int, type[AsyncPacket]] = {int(t): c for t, c in ASYNC_CLASSES.items()}


def _slot_setters(cls: type[AsyncPacket], namespace: dict[str, Any]) -> None:
    """``set_NAME`` in ``namespace`` for every field: the slot's own setter.

    The dataclass is frozen, so its ``__setattr__`` refuses; the slot descriptors
    underneath still store values, and a new object has nothing to protect yet.
    """
    for f in fields(cls):
        namespace[f"set_{f.name}"] = getattr(cls, f.name).__set__


def _compile(
    source: list[str], namespace: dict[str, Any], name: str, cls: type[AsyncPacket]
) -> Callable[..., Any]:
    origin = f"fw1394.packets.fast {name} {cls.__name__}"
    return compile_function(source, namespace, name, origin=origin)


def _encoder(cls: type[AsyncPacket]) -> Callable[[AsyncPacket], bytes | None]:
    """Wire bytes of a packet the engine emits (no CRCs given, data as long as
    ``data_length`` says, nothing trailing), or None for any other packet."""
    layout = cls.LAYOUT
    header = layout.header
    namespace: dict[str, Any] = {
        "pack": header.format.pack,
        "quadlet": _QUADLET.pack,
        "crc": crc32,
        "block_crc": block_crc,
    }
    lines = [
        "def encode(packet):",
        "    if packet.header_crc is not None or packet.trailing:",
        "        return None",
    ]
    if layout.has_data:
        lines += [
            "    data = packet.data",
            "    if packet.data_crc is not None or len(data) != packet.data_length:",
            "        return None",
        ]
    lines += header.attribute_source({"tcode": int(layout.tcode)}, "packet", "head")
    if not layout.has_data:
        lines.append("    return head + quadlet(crc(head))")
    else:
        lines += [
            "    if data_length & 3:",
            "        data = data + bytes(4 - (data_length & 3))",
            "    return b''.join((head, quadlet(crc(head)), data, quadlet(block_crc(data))))",
        ]
    return _compile(lines, namespace, "encode", cls)


def _sound_decoder(cls: type[AsyncPacket]) -> Callable[[bytes], AsyncPacket | None]:
    """The packet if ``raw`` (of this kind) is sound, else None; see :func:`decode_sound`."""
    layout = cls.LAYOUT
    sealed = layout.sealed_header
    size = 4 * sealed.count
    namespace: dict[str, Any] = {
        "new": object.__new__,
        "cls": cls,
        "unpack_from": sealed.format.unpack_from,
        "crc": crc32,
        "block_crc": block_crc,
        "from_bytes": int.from_bytes,
    }
    _slot_setters(cls, namespace)
    quadlets = ", ".join(f"q{i}" for i in range(sealed.count))
    expressions = sealed.field_expressions()
    lines = [
        "def decode(raw):",
        f"    if len(raw) {'<' if layout.has_data else '!='} {size}:",
        "        return None",
        f"    {quadlets} = unpack_from(raw)",
        f"    if crc(raw[:{size - 4}]) != {expressions['header_crc']}:",
        "        return None",
    ]
    if layout.has_data:
        lines += [
            f"    data_length = {expressions['data_length']}",
            f"    end = {size} + data_length + (-data_length & 3)",
            "    if len(raw) != end + 4:",
            "        return None",
            "    data_crc = from_bytes(raw[end:])",
            f"    data = raw[{size}:end]",
            "    if data_crc != block_crc(data):",
            "        return None",
            f"    if end != {size} + data_length:",
            "        data = data[:data_length]",
        ]
    lines.append("    packet = new(cls)")
    for name in sealed.names:
        if name in layout.implied:
            continue
        value = name if name == "data_length" and layout.has_data else expressions[name]
        lines.append(f"    set_{name}(packet, {value})")
    if layout.has_data:
        lines += ["    set_data(packet, data)", "    set_data_crc(packet, data_crc)"]
    lines += ["    set_trailing(packet, b'')", "    return packet"]
    return _compile(lines, namespace, "decode", cls)


_ENCODERS: dict[type[AsyncPacket], Callable[[AsyncPacket], bytes | None]] = {
    cls: _encoder(cls) for cls in _CLASSES.values()
}
_SOUND_DECODERS: dict[int, Callable[[bytes], AsyncPacket | None]] = {
    tcode: _sound_decoder(cls) for tcode, cls in _CLASSES.items()
}


def encode_packet(packet: AsyncPacket) -> bytes:
    """The same bytes as :func:`fw1394.packets.encode`, faster for ordinary packets.

    Packets the engine emits (no CRCs given, ``data_length`` equal to the data's
    length, nothing trailing) are packed by code generated from the layouts; any
    other packet goes through the general codec.
    """
    encoder = _ENCODERS.get(type(packet))
    wire = None if encoder is None else encoder(packet)
    return encode_async(packet) if wire is None else wire


def decode_sound(raw: bytes) -> AsyncPacket | None:
    """The packet if ``raw`` is a sound asynchronous packet (no ``problems``), else None.

    Equal to ``decode_async(raw, strict=True)`` where that succeeds; decoded by
    code generated from the layouts, for the bus's receive path.
    """
    if len(raw) <= TCODE_BYTE:
        return None
    decoder = _SOUND_DECODERS.get(raw[TCODE_BYTE] >> TCODE_SHIFT)
    return None if decoder is None else decoder(raw)


def decode_packet(raw: bytes) -> AsyncPacket:
    """The same packet as ``decode_async(raw)`` (lenient), faster for sound packets."""
    packet = decode_sound(raw)
    return decode_async(raw) if packet is None else packet


# -- building packets ------------------------------------------------------------------
def builder(cls: type[P], *names: str) -> Callable[..., P]:
    """A function making ``cls`` packets from the values of ``names``, in that order.

    The result equals ``cls(**dict(zip(names, values)))``: every other field takes
    its default, and ``data_length``, unless named, the length of ``data``. Made
    for the engine, which builds a packet per transaction: the frozen dataclass's
    own ``__init__`` costs several times as much. Values are stored as given (no
    checks), as the dataclass does; only the encoder looks at their ranges.
    """
    known = {f.name: f for f in fields(cls)}
    unknown = set(names) - set(known)
    if unknown:
        raise TypeError(f"{cls.__name__} has no fields {sorted(unknown)}")
    namespace: dict[str, Any] = {"new": object.__new__, "cls": cls}
    _slot_setters(cls, namespace)
    lines = [f"def build({', '.join(names)}):", "    packet = new(cls)"]
    for name, f in known.items():
        if name in names:
            value = name
        elif f.default is MISSING:
            raise TypeError(f"{cls.__name__}.{name} has no default: name it")
        elif name == "data_length" and f.default == -1:
            # What __post_init__ fills in for a negative length.
            default_data: bytes = known["data"].default  # type: ignore[assignment]
            value = "len(data)" if "data" in names else repr(len(default_data))
        else:
            namespace[f"default_{name}"] = f.default
            value = f"default_{name}"
        lines.append(f"    set_{name}(packet, {value})")
    lines.append("    return packet")
    build: Callable[..., P] = _compile(lines, namespace, "build", cls)
    return build


# -- wire bytes straight from field values ---------------------------------------------
_WORD = re.compile(r"[A-Za-z_][A-Za-z_0-9]*")


def substitute(expression: str, values: dict[str, str]) -> str:
    """``expression`` with each name in ``values`` replaced by its value, parenthesised.

    For the generated packers: a quadlet expression of
    :meth:`fw1394.packets.fields.Quadlets.quadlet_expressions` with some fields
    fixed, which the compiler then folds into constants.
    """

    def value(match: re.Match[str]) -> str:
        name = match[0]
        return f"({values[name]})" if name in values else name

    return _WORD.sub(value, expression)


def wire_builder(cls: type[AsyncPacket], *names: str) -> Callable[..., bytes]:
    """A function making the wire bytes of a ``cls`` packet from the values of ``names``.

    The result equals ``encode_packet(cls(**dict(zip(names, values))))``: every
    other field takes its default, a data block's ``data_length`` is the length
    of ``data``, and both CRCs are computed. No packet object is made. As with
    :func:`builder`, values are not checked: each must fit its field (the
    requester has checked them when it calls this).
    """
    layout = cls.LAYOUT
    known = {f.name: f for f in fields(cls)}
    unknown = set(names) - set(layout.fields) - ({"data"} if layout.has_data else set())
    if unknown:
        raise TypeError(f"{cls.__name__}: cannot build the wire bytes from {sorted(unknown)}")
    if layout.has_data and "data_length" in names:
        raise TypeError(f"{cls.__name__}: data_length is the length of data")
    values = {"tcode": repr(int(layout.tcode))}
    for name in layout.fields:
        if name in names:
            continue
        if name == "data_length" and layout.has_data:
            values[name] = "len(data)" if "data" in names else "0"
            continue
        default = known[name].default
        if not isinstance(default, int):
            raise TypeError(f"{cls.__name__}.{name} has no default: name it")
        values[name] = repr(int(default))
    header = layout.header
    quadlets = ", ".join(substitute(e, values) for e in header.quadlet_expressions())
    lines = [f"def wire({', '.join(names)}):", f"    head = pack({quadlets})"]
    if not layout.has_data:
        lines.append("    return head + quadlet(crc(head))")
    else:
        if "data" not in names:
            lines.append("    data = b''")
        lines += [
            "    if len(data) & 3:",
            "        data = data + bytes(4 - (len(data) & 3))",
            "    return b''.join((head, quadlet(crc(head)), data, quadlet(block_crc(data))))",
        ]
    namespace: dict[str, Any] = {
        "pack": header.format.pack,
        "quadlet": _QUADLET.pack,
        "crc": crc32,
        "block_crc": block_crc,
    }
    wire: Callable[..., bytes] = _compile(lines, namespace, "wire", cls)
    return wire
