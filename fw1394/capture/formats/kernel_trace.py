"""Linux firewire tracepoints (v6.10 and later), one ftrace line at a time.

The kernel prints each event's fields as ``name=value`` (see
``include/trace/events/firewire.h``); arrays as ``{0x..,0x..}`` of 32-bit
values in the CPU's byte order. Header quadlets are kept as numbers, so
they print as their values; but the bytes the kernel copies from the wire
without conversion (the data quadlet of quadlet writes and quadlet read
responses, and every payload) print byte-swapped on a little-endian CPU.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, replace

from fw1394.capture.formats.record import SPEED_UNKNOWN, BusRecord, Direction, RecordType
from fw1394.errors import PacketError
from fw1394.packets import LAYOUTS, TCode
from fw1394.packets.accessors import DESTINATION_ID, SELF_ID_PHY, SOURCE_ID, TCODE
from fw1394.packets.nodeid import phy_of

#: ftrace / trace-cmd / perf prefix: "... 1234.567890: [firewire:]event: fields".
LINE = re.compile(r"(?P<time>\d+\.\d+):\s+(?:firewire:)?(?P<event>[a-z_]+):\s+(?P<fields>.*)$")
FIELD = re.compile(r"(\w+)=(\{[^}]*\}|\S+)")
#: Linux status values above the ack codes (include/linux/firewire-constants.h).
RCODE_NO_ACK = 0x14
#: Header quadlets whose printed value is the raw wire word (see the module docstring).
_RAW_QUADLET_DATA = {TCode.write_quadlet_request, TCode.read_quadlet_response}

REQUEST_EVENTS = {
    "async_request_outbound_initiate": Direction.outbound,
    "async_request_inbound": Direction.inbound,
    "async_response_inbound": Direction.inbound,
    "async_response_outbound_initiate": Direction.outbound,
}
COMPLETE_EVENTS = {"async_request_outbound_complete", "async_response_outbound_complete"}
PHY_EVENTS = {
    "async_phy_outbound_initiate": Direction.outbound,
    "async_phy_inbound": Direction.inbound,
}
KNOWN = {*REQUEST_EVENTS, *COMPLETE_EVENTS, *PHY_EVENTS, "bus_reset_handle", "self_id_sequence"}
KNOWN |= {"bus_reset_initiate", "bus_reset_schedule", "bus_reset_postpone"}
KNOWN |= {"async_phy_outbound_complete"}


class TraceLineError(PacketError):
    """A firewire tracepoint line whose fields do not make sense."""


#: Times are kept as signed 64-bit nanoseconds (about 292 years of uptime).
MAX_TIME_NS = 2**63 - 1


def nanoseconds(seconds: str, fraction: str) -> int:
    """A kernel timestamp's ``seconds`` and ``fraction`` digits, in nanoseconds.

    Raises :class:`TraceLineError` for one no clock reaches (it would not fit
    the 64 bits every record's time is held in).
    """
    time_ns = int(seconds) * 1_000_000_000 + int(fraction.ljust(9, "0")[:9])
    if time_ns > MAX_TIME_NS:
        raise TraceLineError(f"timestamp {seconds}.{fraction} is beyond 64-bit nanoseconds")
    return time_ns


@dataclass
class TraceEvent:
    """What one tracepoint line says."""

    name: str
    time_ns: int
    fields: dict[str, str]
    records: list[BusRecord]
    transaction: str | None = None  # links an outbound initiate to its complete
    status: int | None = None


def ack_of_status(status: int) -> int | None:
    """The ack code behind a Linux status value (None when it is not about an ack)."""
    if status < 0x10:
        return status
    return 0 if status == RCODE_NO_ACK else None


def _array(text: str) -> list[int]:
    inner = text.strip("{}")
    values = [int(value, 16) for value in inner.split(",") if value]
    if any(not 0 <= value <= 0xFFFFFFFF for value in values):
        raise TraceLineError("array value wider than 32 bits")
    return values


def _number(fields: dict[str, str], name: str) -> int:
    try:
        value = int(fields[name], 0)
    except (KeyError, ValueError):
        raise TraceLineError(f"missing or bad {name}=") from None
    if not 0 <= value <= 0xFFFFFFFF:
        raise TraceLineError(f"{name}= is out of range")
    return value


def parse(line: str, little_endian: bool = True) -> TraceEvent | None:
    """The event on ``line``, None if it is not a firewire tracepoint."""
    match = LINE.search(line)
    if match is None or match["event"] not in KNOWN:
        return None
    name = match["event"]
    fields = dict(FIELD.findall(match["fields"]))
    seconds, _, fraction = match["time"].partition(".")
    time_ns = nanoseconds(seconds, fraction)
    event = TraceEvent(name, time_ns, fields, [])
    generation = _number(fields, "generation") if "generation" in fields else 0
    if name in REQUEST_EVENTS:
        event.records.append(
            _async(fields, time_ns, generation, REQUEST_EVENTS[name], little_endian)
        )
        event.transaction = fields.get("transaction")
        if "status" in fields:
            ack = ack_of_status(_number(fields, "status"))
            event.records[0] = _with_ack(event.records[0], ack)
    elif name in COMPLETE_EVENTS:
        event.transaction = fields.get("transaction")
        event.status = _number(fields, "status")
    elif name in PHY_EVENTS:
        quadlets = struct.pack(
            ">II", _number(fields, "first_quadlet"), _number(fields, "second_quadlet")
        )
        event.records.append(
            BusRecord(
                time_ns,
                RecordType.phy_packet,
                quadlets,
                generation,
                direction=PHY_EVENTS[name],
            )
        )
    elif name == "bus_reset_handle":
        local = phy_of(_number(fields, "node_id"))
        event.records.append(
            BusRecord(time_ns, RecordType.bus_reset, b"", generation, observer=local)
        )
        event.records.extend(_self_ids(_array(fields.get("self_ids", "{}")), time_ns, generation))
    elif name == "self_id_sequence":
        event.records.extend(
            _self_ids(_array(fields.get("self_id_sequence", "{}")), time_ns, generation)
        )
    return event


def _with_ack(record: BusRecord, ack: int | None) -> BusRecord:
    return replace(record, ack=ack)


def _self_ids(quadlets: list[int], time_ns: int, generation: int) -> list[BusRecord]:
    return [
        BusRecord(
            time_ns,
            RecordType.phy_packet,
            struct.pack(">I", quadlet),
            generation,
            sender=SELF_ID_PHY((quadlet,)),
            speed=SPEED_UNKNOWN,
            crc_present=False,
            direction=Direction.inbound,
        )
        for quadlet in quadlets
    ]


def _async(
    fields: dict[str, str], time_ns: int, generation: int, direction: Direction, little_endian: bool
) -> BusRecord:
    header = _array(fields.get("header", ""))
    data = _array(fields.get("data", "{}"))
    if len(header) < 3:
        raise TraceLineError("header= has fewer than 3 quadlets")
    tcode = TCODE(header)
    layout = LAYOUTS.get(tcode)  # type: ignore[call-overload]
    if layout is None:
        raise TraceLineError(f"tcode {tcode:#x} has no packet layout")
    count = layout.header.count
    header = (header + [0] * 4)[:count]
    if tcode in _RAW_QUADLET_DATA and little_endian:
        header[3] = int.from_bytes(header[3].to_bytes(4, "little"), "big")
    raw = struct.pack(f">{count}I", *header)
    if layout.has_data:
        order = "<" if little_endian else ">"
        raw += struct.pack(f"{order}{len(data)}I", *data)
    source = SOURCE_ID(header)
    destination = DESTINATION_ID(header)
    local = source if direction == Direction.outbound else destination
    return BusRecord(
        time_ns,
        RecordType.async_packet,
        raw,
        generation,
        sender=phy_of(source),
        speed=_number(fields, "scode") if "scode" in fields else 0xFF,
        crc_present=False,
        direction=direction,
        observer=phy_of(local),
    )
