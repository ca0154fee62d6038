"""Text, JSON and CSV rows for the packet view.

Packet lines follow nosy-dump's packet view: time, then the packet in one
line. Field values use the Linux kernel's names, as everywhere in fw1394.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from fw1394.capture.analysis.columns import Decoded, problem_names
from fw1394.capture.analysis.csr import csr_name
from fw1394.capture.formats.batch import Batch, direction_name
from fw1394.capture.formats.record import RecordType
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    PacketError,
    RCode,
    Speed,
    TCode,
    decode,
    name_of,
)
from fw1394.packets.render import field_rows, hex_preview, summary, to_json

#: Columns of ``--csv`` in the packet view.
PACKET_CSV = (
    "frame",
    "time_s",
    "record_type",
    "generation",
    "speed",
    "direction",
    "sender",
    "ack",
    "tcode",
    "tcode_name",
    "destination_id",
    "source_id",
    "tlabel",
    "retry",
    "priority",
    "offset",
    "rcode",
    "data_length",
    "extended_tcode",
    "quadlet_data",
    "problems",
)


def speed_name(value: int) -> str:
    return name_of(Speed, value) if 0 <= value <= 3 else "-"


def ack_name(value: int) -> str:
    if value < 0:
        return ""
    return "no ack" if value == 0 else name_of(AckCode, value)


class PacketFormatter:
    """Renders the records of a batch."""

    def __init__(self, batch: Batch, decoded: Decoded, origin_ns: int) -> None:
        self.batch = batch
        self.decoded = decoded
        self.origin_ns = origin_ns

    def time(self, row: int) -> float:
        return (int(self.batch.ts_ns[row]) - self.origin_ns) / 1e9

    def time_text(self, row: int) -> str:
        if self.batch.flag("time_unknown")[row]:
            return f"{'-':>14}"  # the log had no clock
        return f"{self.time(row):>14.9f}"

    def packet_object(self, row: int) -> Any:
        """The record decoded by the codec (None for bus resets and unusable bytes)."""
        batch = self.batch
        kind = int(batch.record_type[row])
        raw = batch.packet(row)
        crc = bool(batch.flag("crc_present")[row])
        try:
            if kind == RecordType.async_packet:
                packet = decode(raw, crc=crc, strict=False, kind="async")
                if batch.flag("crc_placeholder")[row] and isinstance(packet, AsyncPacket):
                    # CRCs the sender never computed: show them as absent, not wrong.
                    blank: dict[str, Any] = {"header_crc": None}
                    if hasattr(packet, "data_crc"):
                        blank["data_crc"] = None
                    packet = replace(packet, **blank)
                return packet
            if kind == RecordType.phy_packet:
                return decode(raw, crc=crc, strict=False, kind="phy")
            if kind == RecordType.ack and raw:
                return decode(raw[:1], kind="ack", strict=False)
        except PacketError:
            return None
        return None

    def line(self, row: int) -> str:
        batch, kind = self.batch, int(self.batch.record_type[row])
        head = (
            f"{int(batch.frame[row]):>7}  {self.time_text(row)}  g{int(batch.generation[row]):<3}"
        )
        if kind == RecordType.bus_reset:
            return f"{head} ----  bus reset, generation {int(batch.generation[row])}"
        head += f" {speed_name(int(batch.speed[row])):<4}  "
        if kind == RecordType.async_packet:
            body = self._async(row)
        else:
            packet = self.packet_object(row)
            body = summary(packet) if packet is not None else f"unreadable {RecordType(kind).name}"
        ack = ack_name(int(batch.ack[row]))
        return head + body + (f"  {ack}" if ack else "")

    def _async(self, row: int) -> str:
        decoded = self.decoded
        tcode = int(decoded.tcode[row])
        problems = int(decoded.problems[row])
        if tcode < 0:
            return "short packet " + self.batch.packet(row).hex()
        field = {name: int(values[row]) for name, values in decoded.fields.items()}
        parts = [name_of(TCode, tcode)]
        if field["source_id"] >= 0:
            parts.append(
                f"{field['source_id']:04x} -> {field['destination_id']:04x} tl={field['tlabel']}"
            )
        elif field["channel"] >= 0:
            parts.append(f"channel={field['channel']} tag={field['tag']} sy={field['sy']}")
        if field["offset"] >= 0:
            parts.append(f"offset=0x{field['offset']:012x}")
            name = csr_name(field["offset"])
            if name:
                parts.append(f"[{name}]")
        if field["rcode"] >= 0:
            parts.append(name_of(RCode, field["rcode"]))
        if field["quadlet_data"] >= 0:
            parts.append(f"data={field['quadlet_data']:08x}")
        if field["data_length"] >= 0:
            parts.append(f"len={field['data_length']}")
            start, present = int(decoded.data_start[row]), int(decoded.data_present[row])
            if start >= 0 and present and field["data_length"]:
                shown = min(present, field["data_length"])
                parts.append(
                    "[" + hex_preview(self.batch.buf[start : start + shown].tobytes()) + "]"
                )
        if self.batch.flag("partial")[row]:
            parts.append("[partial: from a log line]")
        elif not self.batch.flag("crc_present")[row]:
            parts.append("[no crc]")
        elif self.batch.flag("crc_placeholder")[row]:
            parts.append("[crc not computed]")
        parts.extend(f"[{text}]" for text in problem_names(problems))
        return " ".join(parts)

    def details(self, row: int) -> list[str]:
        """The ``-v`` lines: record metadata, then every field of the packet."""
        batch = self.batch
        meta = [
            ("record_type", RecordType(int(batch.record_type[row])).name, ""),
            ("direction", direction_name(int(batch.flag("direction")[row])), ""),
            ("sender", _node(int(batch.sender[row])), ""),
            ("observer", _node(int(batch.observer[row])), ""),
            ("position", f"{batch.unit} {int(batch.position[row])}", ""),
        ]
        packet = self.packet_object(row)
        rows = meta + (field_rows(packet) if packet is not None else [])
        width = max(len(name) for name, _, _ in rows)
        return [
            f"    {name:<{width}}  {value}  {meaning}".rstrip() for name, value, meaning in rows
        ]

    def json(self, row: int, verbose: bool) -> dict[str, Any]:
        batch = self.batch
        obj: dict[str, Any] = {
            "frame": int(batch.frame[row]),
            "time_s": round(self.time(row), 9),
            "record_type": RecordType(int(batch.record_type[row])).name,
            "generation": int(batch.generation[row]),
            "speed": speed_name(int(batch.speed[row])),
            "direction": direction_name(int(batch.flag("direction")[row])),
        }
        if int(batch.sender[row]) >= 0:
            obj["sender"] = int(batch.sender[row])
        if int(batch.ack[row]) >= 0:
            obj["ack"] = int(batch.ack[row])
            obj["ack_name"] = ack_name(int(batch.ack[row]))
        packet = self.packet_object(row)
        if packet is not None:
            obj.update(to_json(packet))
        if verbose:
            obj["raw"] = batch.packet(row).hex()
        return obj

    def csv(self, row: int) -> list[str]:
        batch, decoded = self.batch, self.decoded
        tcode = int(decoded.tcode[row])

        def field(name: str) -> str:
            value = int(decoded.fields[name][row])
            return "" if value < 0 else str(value)

        ack = int(batch.ack[row])
        return [
            str(int(batch.frame[row])),
            f"{self.time(row):.9f}",
            RecordType(int(batch.record_type[row])).name,
            str(int(batch.generation[row])),
            speed_name(int(batch.speed[row])),
            direction_name(int(batch.flag("direction")[row])),
            "" if batch.sender[row] < 0 else str(int(batch.sender[row])),
            "" if ack < 0 else str(ack),
            "" if tcode < 0 else str(tcode),
            "" if tcode < 0 else name_of(TCode, tcode),
            field("destination_id"),
            field("source_id"),
            field("tlabel"),
            field("retry"),
            field("priority"),
            field("offset"),
            field("rcode"),
            field("data_length"),
            field("extended_tcode"),
            field("quadlet_data"),
            ";".join(problem_names(int(decoded.problems[row]))),
        ]


def _node(value: int) -> str:
    return "unknown" if value < 0 else f"phy {value}"
