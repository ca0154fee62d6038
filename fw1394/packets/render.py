"""Human and machine views of packets: summary lines, field tables, JSON objects."""

from __future__ import annotations

from enum import IntEnum
from typing import Any

from fw1394.packets.ack import Ack
from fw1394.packets.asynchronous import AsyncPacket, RoutedPacket
from fw1394.packets.enums import ExtendedTCode, PortStatus, RCode, Retry, Speed, TCode, name_of
from fw1394.packets.nodeid import bus_of, phy_of
from fw1394.packets.phy import PhyPacket

Renderable = AsyncPacket | PhyPacket | Ack

#: JSON keys of asynchronous packets, in output order (each where the kind has it).
ASYNC_KEYS = (
    "tcode",
    "tcode_name",
    "destination_id",
    "tlabel",
    "retry",
    "priority",
    "source_id",
    "offset",
    "rcode",
    "data_length",
    "extended_tcode",
    "quadlet_data",
    "data",
    "header_crc",
    "header_crc_ok",
    "data_crc",
    "data_crc_ok",
)
#: Extra keys of stream packets.
STREAM_KEYS = ("tag", "channel", "sy")
#: Keys of PHY packets besides their layout's fields.
PHY_KEYS = ("kind", "quadlet", "inverse", "inverse_ok")
#: Keys of acks.
ACK_KEYS = ("kind", "ack_code", "ack_name", "parity_ok")

ENUM_OF_FIELD: dict[str, type[IntEnum]] = {
    "retry": Retry,
    "rcode": RCode,
    "extended_tcode": ExtendedTCode,
    "scode": Speed,
    "tcode": TCode,
}
_DECIMAL = frozenset(
    {
        "tlabel",
        "tcode",
        "data_length",
        "gap_count",
        "phy_id",
        "root_id",
        "channel",
        "priority",
        "sequence",
        "retry",
        "rcode",
        "extended_tcode",
        "power_class",
        "tag",
        "sy",
        "page",
        "port",
        "register",
        "command",
    }
)
_PREVIEW_QUADLETS = 4


def to_json(packet: Renderable) -> dict[str, Any]:
    """A JSON-ready dict; integers stay numbers, data is a hex string."""
    if isinstance(packet, Ack):
        return dict(zip(ACK_KEYS, ("ack", packet.code, packet.name, packet.parity_ok), strict=True))
    if isinstance(packet, PhyPacket):
        return _phy_json(packet)
    values: dict[str, Any] = {"tcode": int(packet.tcode), "tcode_name": packet.kind}
    stored: dict[str, Any] = {**packet.header_fields(), "header_crc": packet.header_crc}
    data: bytes | None = getattr(packet, "data", None)
    if data is not None:
        stored |= {"data": data.hex(), "data_crc": getattr(packet, "data_crc", None)}
    for key in ASYNC_KEYS[2:]:
        if key in stored:
            values[key] = stored[key]
        elif key == "header_crc_ok":
            values[key] = packet.header_crc_ok
        elif key == "data_crc_ok" and data is not None:
            values[key] = packet.data_crc_ok
    values.update({key: stored[key] for key in STREAM_KEYS if key in stored})
    # Present only when they carry something, so sound packets have the documented keys.
    if stored.get("reserved"):
        values["reserved"] = stored["reserved"]
    if packet.trailing:
        values["trailing"] = packet.trailing.hex()
    if packet.problems:
        values["problems"] = [str(p) for p in packet.problems]
    return values


def _phy_json(packet: PhyPacket) -> dict[str, Any]:
    values: dict[str, Any] = {"kind": packet.kind}
    for name in packet.LAYOUT.names:
        if name in packet.SELECTOR or name in ("identifier", "extended"):
            continue
        value = getattr(packet, name)
        if name != "reserved" or value:
            values[name] = value
    values |= {
        "quadlet": packet.quadlet,
        "inverse": packet.inverse,
        "inverse_ok": packet.inverse_ok,
    }
    if packet.trailing:
        values["trailing"] = packet.trailing.hex()
    if packet.problems:
        values["problems"] = [str(p) for p in packet.problems]
    return values


def hex_preview(data: bytes, quadlets: int = _PREVIEW_QUADLETS) -> str:
    """The first quadlets of ``data`` in hex, and how many more there are."""
    words = [data[i : i + 4].hex() for i in range(0, len(data), 4)]
    more = len(words) - quadlets
    return " ".join(words[:quadlets]) + (f" ... (+{more} quadlets)" if more > 0 else "")


def summary(packet: Renderable) -> str:
    """One line in the spirit of nosy-dump: kind, route, the fields that matter."""
    if isinstance(packet, Ack):
        return packet.name + (" [bad parity]" if packet.parity_ok is False else "")
    if isinstance(packet, PhyPacket):
        return _phy_summary(packet)
    values = to_json(packet)
    parts = [packet.kind]
    if isinstance(packet, RoutedPacket):
        parts.append(f"{packet.source_id:04x} -> {packet.destination_id:04x} tl={packet.tlabel}")
        if packet.retry:
            parts.append(f"rt={name_of(Retry, packet.retry)}")
        if packet.priority:
            parts.append(f"pri={packet.priority}")
    else:
        parts.append(" ".join(f"{key}={values[key]}" for key in STREAM_KEYS))
    if "offset" in values:
        parts.append(f"offset={values['offset']:#014x}")
    if "rcode" in values:
        parts.append(name_of(RCode, values["rcode"]))
    if packet.tcode in (TCode.lock_request, TCode.lock_response):
        parts.append(name_of(ExtendedTCode, values["extended_tcode"]))
    if "quadlet_data" in values:
        parts.append(f"data={values['quadlet_data']:#010x}")
    if "data_length" in values:
        parts.append(f"len={values['data_length']}")
    data: bytes = getattr(packet, "data", b"")
    if data:
        parts.append(f"data={hex_preview(data)}")
    if packet.header_crc is None:
        parts.append("[no crc]")
    parts.extend(f"[{problem}]" for problem in packet.problems)
    return " ".join(parts)


def _phy_summary(packet: PhyPacket) -> str:
    shown = [packet.kind]
    for key, value in _phy_json(packet).items():
        if key in PHY_KEYS or key == "problems" or value is False:
            continue
        if value is True:
            shown.append(key)
        elif key.startswith("port") and len(key) == 5:
            if value != PortStatus.none:
                shown.append(f"{key}={name_of(PortStatus, value)}")
        elif key == "scode":
            shown.append(f"speed={name_of(Speed, value)}")
        else:
            shown.append(f"{key}={value}")
    if packet.inverse is None:
        shown.append("[no check quadlet]")
    shown.extend(f"[{problem}]" for problem in packet.problems)
    return " ".join(shown)


def _text(key: str, value: Any) -> str:
    if value is None:
        return "absent"
    if isinstance(value, bool):
        if key.endswith("_ok"):
            return "ok" if value else "BAD"
        return "yes" if value else "no"
    if isinstance(value, int) and key not in _DECIMAL:
        return f"{value:#x}"
    return str(value)


def _meaning(key: str, value: Any) -> str:
    if isinstance(value, bool) or not isinstance(value, int):
        return ""
    if key in ENUM_OF_FIELD:
        return name_of(ENUM_OF_FIELD[key], value)
    if key in ("destination_id", "source_id"):
        return f"bus {bus_of(value):#x}, node {phy_of(value)}"
    if key.startswith("port") and len(key) == 5:
        return name_of(PortStatus, value)
    return ""


def field_rows(packet: Renderable) -> list[tuple[str, str, str]]:
    """(field, value, meaning) rows for a detailed view."""
    values = to_json(packet)
    if isinstance(packet, Ack):
        values["parity"] = packet.parity
    rows: list[tuple[str, str, str]] = []
    for key, value in values.items():
        if key == "problems":
            rows.extend(("problem", str(problem), "") for problem in value)
        else:
            rows.append((key, _text(key, value), _meaning(key, value)))
    return rows
