"""Configuration ROMs: rebuilt from the reads seen in a trace, decoded, CRC-checked.

A node's configuration ROM (IEEE 1212 / 1394) starts at CSR offset 0x400:
a bus information block, then the root directory, whose entries point to
leaves and further directories. Each block starts with a header quadlet
(length in quadlets, CRC-16 of that many following quadlets); the CRC is
the IEEE 1212 CRC-16 over the big-endian bytes.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, field
from typing import Any

from fw1394.capture.analysis.csr import CONFIG_ROM, CONFIG_ROM_END, CSR_BASE
from fw1394.crc import crc16_1212
from fw1394.packets.fields import Quadlets

#: The bus information block of IEEE 1394 (after its header quadlet).
BUS_INFO = Quadlets(
    (("bus_name", 32),),
    (
        ("irmc", 1),
        ("cmc", 1),
        ("isc", 1),
        ("bmc", 1),
        ("pmc", 1),
        ("reserved", 3),
        ("cyc_clk_acc", 8),
        ("max_rec", 4),
        ("reserved", 2, 2),
        ("max_rom", 2),
        ("generation", 4),
        ("reserved", 1, 1),
        ("link_spd", 3),
    ),
    (("node_vendor_id", 24), ("chip_id", 8, 32)),
    (("chip_id", 32),),
)
BLOCK_HEADER = Quadlets((("length", 16), ("crc", 16)))
ROM_HEADER = Quadlets((("info_length", 8), ("crc_length", 8), ("crc", 16)))
ENTRY = Quadlets((("key_type", 2), ("key_id", 6), ("value", 24)))
BUS_NAME_1394 = 0x31333934

#: IEEE 1212-2001 key IDs.
KEY_NAMES = {
    0x01: "Descriptor",
    0x02: "Bus_Dependent_Info",
    0x03: "Vendor",
    0x04: "Hardware_Version",
    0x07: "Module",
    0x0C: "Node_Capabilities",
    0x0D: "EUI_64",
    0x11: "Unit",
    0x12: "Specifier_ID",
    0x13: "Version",
    0x14: "Dependent_Info",
    0x15: "Unit_Location",
    0x17: "Model",
    0x18: "Instance",
    0x19: "Keyword",
    0x1A: "Feature",
    0x20: "Directory_ID",
    0x21: "Revision",
}
KEY_TYPES = ("immediate", "csr_offset", "leaf", "directory")
_MAX_BLOCKS = 64


def _pack(quadlets: Quadlets, **values: int) -> int:
    return int(struct.unpack(">I", quadlets.pack(values))[0])


def _unpack(quadlets: Quadlets, *values: int) -> dict[str, int]:
    return quadlets.unpack_fields(struct.pack(f">{len(values)}I", *values))


# -- building (the simulator and the tests need realistic ROMs) -----------------------------


def block(content: list[int]) -> list[int]:
    """A leaf or directory: header quadlet with length and CRC-16, then ``content``."""
    crc = crc16_1212(struct.pack(f">{len(content)}I", *content))
    return [_pack(BLOCK_HEADER, length=len(content), crc=crc), *content]


def text_leaf(text: str) -> list[int]:
    raw = text.encode("ascii", "replace")
    raw += bytes(-len(raw) % 4)
    return block([0, 0, *struct.unpack(f">{len(raw) // 4}I", raw)])


def entry(key_type: int, key_id: int, value: int) -> int:
    return _pack(ENTRY, key_type=key_type, key_id=key_id, value=value)


def build_rom(
    vendor_id: int, model_id: int, eui64: int, vendor: str, model: str, max_rec: int = 8
) -> list[int]:
    """A small but complete ROM: bus info block, root directory, text leaves, a unit."""
    fields = {"irmc": 0, "cmc": 1, "isc": 0, "bmc": 0, "pmc": 0, "reserved": 0}
    fields |= {"cyc_clk_acc": 0xFF, "max_rec": max_rec, "max_rom": 0, "generation": 2}
    fields |= {"link_spd": 2, "bus_name": BUS_NAME_1394}
    fields |= {"node_vendor_id": eui64 >> 40, "chip_id": eui64 & 0xFF_FFFF_FFFF}
    info = list(struct.unpack(">4I", BUS_INFO.pack(fields)))
    vendor_leaf, model_leaf = text_leaf(vendor), text_leaf(model)
    unit = block([entry(0, 0x12, vendor_id), entry(0, 0x13, 0x000001), entry(0, 0x17, model_id)])
    root_length = 6
    after = [0, len(vendor_leaf), len(vendor_leaf) + len(model_leaf)]

    def pointer(index: int, position: int) -> int:
        # Entry ``index`` points at the block ``position`` quadlets after the root directory.
        return root_length - index + position

    root = block(
        [
            entry(0, 0x03, vendor_id),
            entry(2, 0x01, pointer(1, after[0])),
            entry(0, 0x17, model_id),
            entry(2, 0x01, pointer(3, after[1])),
            entry(0, 0x0C, 0x0083C0),
            entry(3, 0x11, pointer(5, after[2])),
        ]
    )
    body = [*info, *root, *vendor_leaf, *model_leaf, *unit]
    crc = crc16_1212(struct.pack(f">{len(info)}I", *info))
    header = _pack(ROM_HEADER, info_length=len(info), crc_length=len(info), crc=crc)
    return [header, *body]


# -- decoding -------------------------------------------------------------------------------


@dataclass
class RomBlock:
    """A directory or leaf found in a ROM."""

    kind: str
    address: int  # CSR offset (0x400 ...)
    length: int | None
    crc_ok: bool | None
    entries: list[dict[str, Any]] = field(default_factory=list)
    text: str | None = None
    quadlets: list[int] = field(default_factory=list)


@dataclass
class RomReport:
    """What the quadlets read from one node's ROM say."""

    bus_info: dict[str, int] = field(default_factory=dict)
    bus_info_crc_ok: bool | None = None
    blocks: list[RomBlock] = field(default_factory=list)
    missing: list[int] = field(default_factory=list)

    @property
    def eui64(self) -> int | None:
        if "node_vendor_id" not in self.bus_info:
            return None
        return self.bus_info["node_vendor_id"] << 40 | self.bus_info["chip_id"]


def decode_rom(quadlets: dict[int, int]) -> RomReport:
    """Decode a ROM from ``{CSR offset: quadlet}`` (offsets 0x400.., as read)."""
    quadlets = {a: q for a, q in quadlets.items() if 0 <= q <= 0xFFFFFFFF}
    report = RomReport()
    if CONFIG_ROM not in quadlets:
        report.missing.append(CONFIG_ROM)
        return report
    head = _unpack(ROM_HEADER, quadlets[CONFIG_ROM])
    info = [quadlets.get(CONFIG_ROM + 4 * (1 + i)) for i in range(head["info_length"])]
    if len(info) >= BUS_INFO.count and all(q is not None for q in info[:4]):
        report.bus_info = _unpack(BUS_INFO, *[q for q in info[:4] if q is not None])
        report.bus_info.pop("reserved", None)
    report.bus_info_crc_ok = _crc_ok(quadlets, CONFIG_ROM, head["crc_length"], head["crc"], report)
    pending = [("root_directory", CONFIG_ROM + 4 * (1 + head["info_length"]))]
    seen: set[int] = set()
    while pending and len(report.blocks) < _MAX_BLOCKS:
        kind, address = pending.pop(0)
        if address in seen or not CONFIG_ROM <= address < CONFIG_ROM_END:
            continue
        seen.add(address)
        found = _block(quadlets, kind, address, report)
        report.blocks.append(found)
        for item in found.entries:
            if "target" in item:
                pending.append((item["target_kind"], item["target"]))
    return report


def _crc_ok(
    quadlets: dict[int, int], address: int, count: int, stored: int, report: RomReport
) -> bool | None:
    covered = [quadlets.get(address + 4 * (1 + i)) for i in range(count)]
    missing = [address + 4 * (1 + i) for i, q in enumerate(covered) if q is None]
    if missing:
        report.missing.extend(a for a in missing if a not in report.missing)
        return None
    return crc16_1212(struct.pack(f">{count}I", *covered)) == stored


def _block(quadlets: dict[int, int], kind: str, address: int, report: RomReport) -> RomBlock:
    if address not in quadlets:
        report.missing.append(address)
        return RomBlock(kind, address, None, None)
    head = _unpack(BLOCK_HEADER, quadlets[address])
    length = min(head["length"], (CONFIG_ROM_END - address) // 4 - 1)
    found = RomBlock(
        kind, address, head["length"], _crc_ok(quadlets, address, length, head["crc"], report)
    )
    content = [quadlets.get(address + 4 * (1 + i)) for i in range(length)]
    found.quadlets = [q for q in content if q is not None]
    if kind.endswith("directory"):
        for index, value in enumerate(content):
            if value is not None:
                found.entries.append(_entry(address + 4 * (1 + index), value))
    elif len(content) >= 2 and content[0] == 0 and content[1] == 0 and None not in content:
        raw = struct.pack(f">{len(content) - 2}I", *[q for q in content[2:] if q is not None])
        found.text = raw.rstrip(b"\0").decode("ascii", "replace")
    return found


def _entry(address: int, value: int) -> dict[str, Any]:
    fields = _unpack(ENTRY, value)
    key_type, key_id, data = fields["key_type"], fields["key_id"], fields["value"]
    item: dict[str, Any] = {
        "address": address,
        "key_type": KEY_TYPES[key_type],
        "key_id": key_id,
        "key": KEY_NAMES.get(key_id, f"key_{key_id:#04x}"),
        "value": data,
    }
    if key_type == 1:
        item["csr_offset"] = CSR_BASE + 4 * data
    elif key_type >= 2:
        item["target"] = address + 4 * data
        item["target_kind"] = "leaf" if key_type == 2 else f"{item['key'].lower()}_directory"
    return item


def report_lines(report: RomReport) -> list[str]:
    """The report as indented text lines."""
    lines = []
    if report.bus_info:
        info = report.bus_info
        crc = {True: "crc ok", False: "CRC ERROR", None: "crc unchecked"}[report.bus_info_crc_ok]
        lines.append(
            f"bus info block: bus_name={info['bus_name']:#010x} eui64={report.eui64:016x} "
            f"max_rec={info['max_rec']} link_spd={info['link_spd']} generation={info['generation']}"
            f" irmc={info['irmc']} cmc={info['cmc']} isc={info['isc']} bmc={info['bmc']} [{crc}]"
        )
    for found in report.blocks:
        crc = {True: "crc ok", False: "CRC ERROR", None: "crc unchecked"}[found.crc_ok]
        lines.append(f"{found.kind} at {found.address:#05x}: {found.length} quadlets [{crc}]")
        for item in found.entries:
            target = f" -> {item['target']:#05x}" if "target" in item else ""
            lines.append(f"    {item['key']} ({item['key_type']}) = {item['value']:#08x}{target}")
        if found.text is not None:
            lines.append(f"    text: {found.text!r}")
    if report.missing:
        lines.append("not read: " + ", ".join(f"{a:#05x}" for a in sorted(set(report.missing))))
    return lines
