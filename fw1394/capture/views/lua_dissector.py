"""The Wireshark Lua dissector, generated from fw1394's own definitions.

Nothing in the generated file is written by hand twice: packet fields come
from the layouts' ``Quadlets.bitfields`` (and the PHY packet layouts), the
pseudo-header and the Eth1394 framing from their ``construct`` structs, value
names from the enums, and the PHY packet dispatch from asking the codec which
kind each identifier/type combination is. :mod:`fw1394.capture.views.lua_runtime`
holds the fixed Lua code that walks these tables.
"""

from __future__ import annotations

import itertools
from collections.abc import Iterable
from enum import IntEnum

from construct import Struct

from fw1394.capture.analysis.transaction_model import (
    DEFAULT_EXPIRY_NS,
    ERROR_ACKS,
    NO_ACK,
    RETRY_ACKS,
    WRITES,
)
from fw1394.capture.formats import pseudo_header
from fw1394.capture.formats.record import Direction, RecordType
from fw1394.capture.views.lua_runtime import RUNTIME
from fw1394.crc import crc32
from fw1394.packets import LAYOUTS, PHY_CLASSES, PacketError
from fw1394.packets.accessors import PHY_KIND_BITS, TCODE, FieldReader
from fw1394.packets.ack import ACK_LAYOUT
from fw1394.packets.bitfields import BitField, flatten
from fw1394.packets.enums import AckCode, ExtendedTCode, RCode, Retry, Speed, TCode
from fw1394.packets.eth1394 import (
    CONTROL_WORD,
    CONTROL_WORD_SIZE,
    EXTRA_BYTES,
    EXTRA_SIZE,
    UDP_PORT,
)
from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.packets.phy import PhyPacket, phy_class_of
from fw1394.packets.tcodes import REQUEST_TCODES, RESPONSE_OF_REQUEST, RESPONSE_TCODES
from fw1394.version import __version__

#: Field names as the Linux kernel's firewire tracepoints spell them.
KERNEL_NAMES = {"destination_id": "dst_id", "source_id": "src_id"}
#: Fields shown in hex; the others in decimal.
_HEX = {"dst_id", "src_id", "offset", "quadlet_data", "header_crc", "data_crc", "reserved"}
_VALUE_NAMES: dict[str, type[IntEnum]] = {
    "tcode": TCode,
    "rcode": RCode,
    "retry": Retry,
    "extended_tcode": ExtendedTCode,
}
#: The ack byte's code and parity nibbles as flat rows (byte 0 of an ack record).
ACK_FIELDS = {field.name: field for field in flatten(Struct("ack" / ACK_LAYOUT))}


def kernel_name(name: str) -> str:
    return KERNEL_NAMES.get(name, name)


def _lua_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _lua_set(values: Iterable[int]) -> str:
    return "{ " + ", ".join(f"[{int(value)}] = true" for value in sorted(values)) + " }"


def _value_table(enum: type[IntEnum]) -> str:
    items = ", ".join(f"[{int(member)}] = {_lua_string(member.name)}" for member in enum)
    return "{ " + items + " }"


def _bitfields_table(bitfields: Iterable[BitField], prefix: str = "") -> str:
    rows = []
    for bit in bitfields:
        rows.append(
            f"{{ {_lua_string(prefix + kernel_name(bit.name))}, {bit.quadlet}, {bit.lsb}, "
            f"{bit.mask:#x}, {bit.shift} }}"
        )
    return "{ " + ", ".join(rows) + " }"


def _flat_table(fields: Iterable[BitField], prefix: str) -> str:
    rows = []
    for field in fields:
        rows.append(_flat_row(field, prefix + field.name.replace(".", "_")))
    return "{ " + ", ".join(rows) + " }"


def _reader_row(reader: FieldReader) -> str:
    """A one-quadlet field as a row ``flat_value`` reads: bytes, shift and mask from its layout."""
    first, size, shift = reader.byte_span
    width = reader.parts[0].width
    row = BitField(reader.name, first, size, shift + width - 1, width)
    return _flat_row(row, reader.name)


def _flat_row(field: BitField, name: str) -> str:
    return (
        f"{{ {_lua_string(name)}, {field.byte_offset}, {field.byte_size}, {field.lsb}, "
        f"{field.mask:#x}, {_lua_string(field.name)} }}"
    )


def _phy_kind_index(values: Iterable[int]) -> int:
    """Index of PHY_DISPATCH: the kind bits (:data:`PHY_KIND_BITS`) side by side."""
    index = 0
    for reader, value in zip(PHY_KIND_BITS, values, strict=True):
        index = index << reader.parts[0].width | value
    return index


def _phy_kind_rows() -> str:
    # Each kind bit field as { lsb, mask, weight in the dispatch index }.
    rows, weight = [], 1
    for reader in reversed(PHY_KIND_BITS):
        rows.append(f"{{ {reader.shift}, {reader.mask:#x}, {weight} }}")
        weight <<= reader.parts[0].width
    return "{ " + ", ".join(reversed(rows)) + " }"


def _async_layouts() -> str:
    lines = []
    for tcode, layout in LAYOUTS.items():
        lines.append(
            f"  [{int(tcode)}] = {{ name = {_lua_string(layout.name)}, "
            f"quadlets = {layout.header.count}, has_data = {str(layout.has_data).lower()}, "
            f"fields = {_bitfields_table(layout.header.bitfields)} }},"
        )
    return "{\n" + "\n".join(lines) + "\n}"


def _phy_layouts() -> tuple[str, str]:
    classes = _phy_classes()
    index = {cls: number + 1 for number, cls in enumerate(classes)}
    layouts = [
        f"  [{index[cls]}] = {{ name = {_lua_string(cls.NAME)}, "
        f"fields = {_bitfields_table(cls.LAYOUT.bitfields, 'phy_')} }},"
        for cls in classes
    ]
    # Which kind each combination of the kind bits makes, asked of the codec itself.
    dispatch = []
    for values in itertools.product(*(range(r.mask + 1) for r in PHY_KIND_BITS)):
        probe = sum(value << r.shift for r, value in zip(PHY_KIND_BITS, values, strict=True))
        try:
            cls = phy_class_of(probe)
        except PacketError:
            continue
        dispatch.append(f"[{_phy_kind_index(values)}] = {index[cls]}")
    return "{\n" + "\n".join(layouts) + "\n}", "{ " + ", ".join(dispatch) + " }"


def _proto_field(key: str, abbrev: str, label: str, width: int, base: str, names: str) -> str:
    if width > 32:
        value_names = names.removeprefix(", ") or "nil"
        field = (
            f"wide_field({_lua_string(key)}, {_lua_string(abbrev)}, {_lua_string(label)}, "
            f"{width}, {base}, {value_names})"
        )
    else:
        kind = "uint8" if width <= 8 else "uint16" if width <= 16 else "uint32"
        field = f'ProtoField.{kind}("{abbrev}", {_lua_string(label)}, {base}{names})'
    return f"F[{_lua_string(key)}] = {field}"


#: Fields wider than 32 bits (the 48-bit offset) as wide as they are: Wireshark's Lua
#: offers 40 to 56-bit fields only in some versions; elsewhere the field is 64-bit and
#: its label shows the real width (WIDE tells the runtime which fields need that).
WIDE_FIELD = """\
local WIDE = {}
local function wide_field(key, abbrev, label, width, display, names)
  local bits = 8 * math.ceil(width / 8)
  local ok, field = pcall(ProtoField.new, label, abbrev, ftypes["UINT" .. bits], names, display)
  if ok and field then return field end
  WIDE[key] = bits / 4
  return ProtoField.uint64(abbrev, label, display, names)
end"""


def _crc_table() -> str:
    """The byte-at-a-time table of the 1394 CRC-32, read off :func:`fw1394.crc.crc32`.

    The CRC is affine in its message, so the register change one byte makes
    from zero is the CRC of that byte minus (XOR) the CRC of a zero byte.
    """
    zero = crc32(b"\0")
    return "{ [0] = " + ", ".join(f"{crc32(bytes([b])) ^ zero:#010x}" for b in range(256)) + " }"


def _response_table() -> str:
    items = ", ".join(f"[{int(req)}] = {int(resp)}" for req, resp in RESPONSE_OF_REQUEST.items())
    return "{ " + items + " }"


def _field_declarations() -> list[str]:
    widths: dict[str, int] = {"data_crc": 32}
    for layout in LAYOUTS.values():
        for name in layout.sealed_header.names:
            key = kernel_name(name)
            widths[key] = max(widths.get(key, 0), layout.sealed_header.widths[name])
    lines = []
    for name, width in widths.items():
        base = "base.HEX" if name in _HEX else "base.DEC"
        names = f", {name}_names" if name in _VALUE_NAMES else ""
        lines.append(_proto_field(name, f"fw1394.{name}", name, width, base, names))
    phy_widths: dict[str, int] = {}
    for cls in _phy_classes():
        for name in cls.LAYOUT.names:
            phy_widths[name] = max(phy_widths.get(name, 0), cls.LAYOUT.widths[name])
    for name, width in phy_widths.items():
        lines.append(_proto_field(f"phy_{name}", f"fw1394.phy.{name}", name, width, "base.DEC", ""))
    return lines


def _phy_classes() -> list[type[PhyPacket]]:
    return list(PHY_CLASSES.values()) if isinstance(PHY_CLASSES, dict) else list(PHY_CLASSES)


def generate() -> str:
    """The complete Lua dissector."""
    phy_layouts, phy_dispatch = _phy_layouts()
    header = pseudo_header.FIELDS.values()
    tables = [
        f"-- fw1394.lua: IEEE 1394 dissector generated by fw1394 {__version__}.",
        "-- Regenerate with `fw1394 wireshark-dissector > fw1394.lua`; do not edit.",
        "-- Use: wireshark -X lua_script:fw1394.lua trace.pcapng, or copy it to the",
        "-- personal Lua plugins folder (Help > About Wireshark > Folders).",
        "",
        f"local LINKTYPE = {pseudo_header.LINKTYPE_FW1394}",
        f"local PSEUDO_HEADER_VERSION = {pseudo_header.VERSION}",
        f"local PSEUDO_HEADER_LENGTH = {pseudo_header.HEADER_LENGTH}",
        f"local UDP_PORT = {UDP_PORT}",
        f"local CONTROL_WORD_SIZE = {CONTROL_WORD_SIZE}",
        f"local EXTRA_SIZE = {EXTRA_SIZE}",
        f"local REQUEST_TCODES = {_lua_set(REQUEST_TCODES)}",
        f"local RESPONSE_TCODES = {_lua_set(RESPONSE_TCODES)}",
        f"local TCODE = {_reader_row(TCODE)}",
        f"local TCODE_END = {TCODE.end}",
        f"local ACK_CODE = {_flat_row(ACK_FIELDS['ack.code'], 'ack_code')}",
        f"local ACK_PARITY = {_flat_row(ACK_FIELDS['ack.parity'], 'ack_parity')}",
        f"local PHY_KIND_BITS = {_phy_kind_rows()}",
        f"local RESPONSE_OF_REQUEST = {_response_table()}",
        f"local RETRY_ACKS = {_lua_set(RETRY_ACKS.tolist())}",
        f"local WRITE_TCODES = {_lua_set(WRITES.tolist())}",
        f"local ERROR_ACKS = {_lua_set(ERROR_ACKS.tolist())}",
        f"local ACK_COMPLETE = {int(AckCode.ack_complete)}",
        f"local NO_ACK = {NO_ACK}",
        f"local BROADCAST_PHY = {BROADCAST_PHY}",
        f"local EXPIRY_SECONDS = {DEFAULT_EXPIRY_NS / 1e9!r}",
        f"local CRC_TABLE = {_crc_table()}",
        f"local tcode_names = {_value_table(TCode)}",
        f"local rcode_names = {_value_table(RCode)}",
        f"local retry_names = {_value_table(Retry)}",
        f"local extended_tcode_names = {_value_table(ExtendedTCode)}",
        f"local ack_names = {_value_table(AckCode)}",
        'ack_names[0] = "no ack"',
        f"local speed_names = {_value_table(Speed)}",
        f"local record_type_names = {_value_table(RecordType)}",
        f"local direction_names = {_value_table(Direction)}",
        f"local ASYNC = {_async_layouts()}",
        f"local PHY = {phy_layouts}",
        f"local PHY_DISPATCH = {phy_dispatch}",
        f"local PSEUDO_HEADER = {_flat_table(header, 'ph_')}",
        f"local CONTROL_WORD = {_flat_table(flatten(CONTROL_WORD), 'control_')}",
        f"local EXTRA_BYTES = {_flat_table(flatten(EXTRA_BYTES), 'extra_')}",
        "",
        'local fw1394 = Proto("fw1394", "IEEE 1394 (fw1394 trace)")',
        'local eth1394 = Proto("eth1394", "JHU Eth1394 (IEEE 1394 over UDP)")',
        "local F = {}",
        WIDE_FIELD,
        *_field_declarations(),
    ]
    return "\n".join(tables) + "\n" + RUNTIME
