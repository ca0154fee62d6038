"""Ways to break a packet, each a pure function of wire bytes and a few parameters.

Hypothesis strategies (:mod:`fw1394.fuzz.strategies`) and the fast generator
(:mod:`fw1394.fuzz.generate`) draw the parameters; both go through these
functions, so a malformed packet means the same thing in both. Where a field
sits comes from :mod:`fw1394.packets` (the layouts' generated header packers
and unpackers), never from here; the functions touch only the header, so they
stay cheap enough to run for every case.
"""

from __future__ import annotations

from fw1394.crc import crc32, padded
from fw1394.packets import LAYOUTS, AsyncPacket, Layout, PacketError
from fw1394.packets.accessors import TCODE
from fw1394.packets.asynchronous import decode_async, encode_async, tcode_of
from fw1394.packets.fast import HEADER_SIZES

_QUADLET = 4
_LAYOUTS: dict[int, Layout] = {int(tcode): layout for tcode, layout in LAYOUTS.items()}
#: Transaction codes no asynchronous layout defines (0xE is the link-internal PHY code).
UNKNOWN_TCODES = tuple(sorted(set(range(16)) - set(_LAYOUTS)))


def header_size(raw: bytes) -> int | None:
    """Bytes of the header with its CRC quadlet, or None for an unknown tcode."""
    if len(raw) < _QUADLET:
        return None
    return HEADER_SIZES.get(tcode_of(raw))


def header_of(raw: bytes) -> tuple[Layout, dict[str, int]] | None:
    """The layout and header field values of ``raw`` (None: unknown tcode or too short)."""
    size = header_size(raw)
    if size is None or len(raw) < size:
        return None
    layout = _LAYOUTS[tcode_of(raw)]
    return layout, layout.header.unpack_fields(raw[: size - _QUADLET])


def sealed(header: bytes) -> bytes:
    """``header`` followed by its correct CRC quadlet."""
    return header + crc32(header).to_bytes(_QUADLET, "big")


def lenient(raw: bytes) -> AsyncPacket | None:
    """The packet as a lenient decoder sees it, or None when nothing can be made of it."""
    try:
        return decode_async(raw)
    except PacketError:
        return None


def flip_header_crc(raw: bytes, mask: int) -> bytes:
    """``raw`` with its header CRC quadlet XORed with ``mask`` (nonzero: a wrong CRC)."""
    size = header_size(raw)
    if size is None or len(raw) < size:
        return raw
    crc = int.from_bytes(raw[size - _QUADLET : size], "big") ^ (mask & 0xFFFFFFFF)
    return raw[: size - _QUADLET] + crc.to_bytes(_QUADLET, "big") + raw[size:]


def flip_data_crc(raw: bytes, mask: int) -> bytes:
    """``raw`` with its last quadlet (the data CRC of a block packet) XORed with ``mask``."""
    size = header_size(raw)
    if size is None or len(raw) < size + _QUADLET:
        return raw
    crc = int.from_bytes(raw[-_QUADLET:], "big") ^ (mask & 0xFFFFFFFF)
    return raw[:-_QUADLET] + crc.to_bytes(_QUADLET, "big")


def without_crcs(raw: bytes) -> bytes:
    """The header and data with no CRC quadlets at all (as a kernel log prints them)."""
    packet = lenient(raw)
    if packet is None:
        return raw
    try:
        return encode_async(packet, crc=False)
    except PacketError:
        return raw


def truncated(raw: bytes, keep: int) -> bytes:
    """The first ``keep`` bytes (at least one, fewer than all when possible)."""
    return raw[: max(1, min(keep, len(raw) - 1))]


def over_long(raw: bytes, extra: bytes) -> bytes:
    """``raw`` followed by ``extra``: bytes past the end of the packet."""
    return raw + extra


def with_header(raw: bytes, changes: dict[str, int], *, fix_crc: bool) -> bytes:
    """``raw`` with header fields set as in ``changes`` (values cut to their widths).

    The header CRC is recomputed with ``fix_crc``; otherwise the old one stays,
    which then no longer matches. A field the layout lacks is ignored; so is
    the tcode (see :func:`with_tcode`). Bytes after the header are kept.
    """
    found = header_of(raw)
    if found is None:
        return raw
    layout, fields = found
    quadlets = layout.header
    widths = quadlets.widths
    for name, value in changes.items():
        if name in widths and name != "tcode":
            fields[name] = value & ((1 << widths[name]) - 1)
    size = _QUADLET * layout.sealed_header.count
    # Every value was cut to its width above, so the unchecked packer is safe.
    header = quadlets.format.pack(*quadlets.pack_fields(fields))
    crc = crc32(header).to_bytes(_QUADLET, "big") if fix_crc else raw[size - _QUADLET : size]
    return header + crc + raw[size:]


def with_data_length(raw: bytes, length: int, *, fix_crc: bool) -> bytes:
    """A block packet whose ``data_length`` says ``length`` whatever data it carries.

    With ``fix_crc`` the header CRC covers the new length, so the packet gets
    past a header CRC check and only the length disagrees.
    """
    found = header_of(raw)
    if found is None or not found[0].has_data:
        return raw
    return with_header(raw, {"data_length": length}, fix_crc=fix_crc)


def with_tcode(raw: bytes, tcode: int) -> bytes:
    """The header of ``raw`` packed again with another tcode, header CRC recomputed.

    With an unknown tcode the bytes after the header are kept as they were, so
    a parser that guesses a layout has something to read.
    """
    found = header_of(raw)
    if found is None:
        return raw
    layout, fields = found
    fields["tcode"] = tcode & TCODE.mask
    size = _QUADLET * layout.sealed_header.count
    return sealed(layout.header.pack(fields)) + raw[size:]


def recomputed_crcs(raw: bytes) -> bytes | None:
    """``raw`` with correct CRC quadlets (data_length kept as given), or None if undecodable.

    Mutated packets pass through this so that they get past the CRC check
    and reach the parser's later stages. Bytes past the packet stay.
    """
    found = header_of(raw)
    if found is None:
        return None
    layout, fields = found
    size = _QUADLET * layout.sealed_header.count
    header = sealed(raw[: size - _QUADLET])
    if not layout.has_data:
        return header + raw[size:]
    length = fields["data_length"]
    block = padded(raw[size : size + length])
    end = size + len(block)
    if len(raw) < end + _QUADLET:
        # Cut short: the codec rebuilds what arrived, with a CRC over it.
        packet = lenient(raw)
        return None if packet is None else _encoded(packet.with_crcs(), raw)
    return header + block + crc32(block).to_bytes(_QUADLET, "big") + raw[end + _QUADLET :]


def _encoded(packet: AsyncPacket, fallback: bytes) -> bytes:
    try:
        return encode_async(packet)
    except PacketError:
        return fallback
