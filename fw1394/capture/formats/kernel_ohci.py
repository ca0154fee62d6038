"""The firewire-ohci ``debug`` log of older kernels, as pasted into bug reports.

With ``modprobe firewire-ohci debug=7`` the driver logged every packet it
sent ("AT") or received ("AR"), bus resets and self-IDs (see
``log_ar_at_event`` and ``log_selfids`` in ``drivers/firewire/ohci.c``,
removed in 2025). Only some header fields were printed, so packets rebuilt
from these lines are marked *partial*: retry, priority, rcode and the data
block are unknown.
"""

from __future__ import annotations

import re
import struct
from dataclasses import dataclass, field

from fw1394.capture.formats.record import SPEED_UNKNOWN, BusRecord, Direction, RecordType
from fw1394.packets import LAYOUTS, AckCode, TCode
from fw1394.packets.accessors import SELF_ID_PHY
from fw1394.packets.nodeid import phy_of

#: ohci.c's names for the tcodes in its log lines.
TCODE_NAMES = {
    "QW req": TCode.write_quadlet_request,
    "BW req": TCode.write_block_request,
    "W resp": TCode.write_response,
    "QR req": TCode.read_quadlet_request,
    "BR req": TCode.read_block_request,
    "QR resp": TCode.read_quadlet_response,
    "BR resp": TCode.read_block_response,
    "cycle start": TCode.cycle_start,
    "Lk req": TCode.lock_request,
    "Lk resp": TCode.lock_response,
}
#: Event names that carry an ack; the others (evt_*) describe a failure.
ACKS = {code.name: int(code) for code in AckCode}
_EVENT = r"(?P<evt>[-a-z_/A-Z ]+?)\s*"
PACKET = re.compile(
    r"\bA(?P<dir>[TR]) spd (?P<spd>\d) tl (?P<tl>[0-9a-f]{2}), (?P<src>[0-9a-f]{4}) -> "
    r"(?P<dst>[0-9a-f]{4}), " + _EVENT + r", (?P<tname>[^,]+?)"
    r"(?:, (?P<addr>[0-9a-f]{12}))?(?P<specific> = [0-9a-f]{8}| [0-9a-f]+,[0-9a-f]+)?\s*$"
)
BUS_RESET = re.compile(r"\bA(?P<dir>[TR]) evt_bus_reset, generation (?P<gen>\d+)")
PHY = re.compile(r"\bA(?P<dir>[TR]) " + _EVENT + r", PHY (?P<q>[0-9a-f]{8}) (?P<inv>[0-9a-f]{8})")
STREAM = re.compile(r"\bA[TR] [^,]*, async stream packet")
SELF_IDS = re.compile(
    r"(?P<n>\d+) selfIDs, generation (?P<gen>\d+), local node ID (?P<id>[0-9a-f]{4})"
)
SELF_ID = re.compile(r"selfID [0n]: (?P<q>[0-9a-f]{8}), phy")


@dataclass
class OhciState:
    """What earlier lines told: the bus generation and the local node."""

    generation: int = 0
    local: int | None = None
    announced: set[int] = field(default_factory=set)


def parse(line: str, time_ns: int, state: OhciState) -> list[BusRecord] | None:
    """Records for one log line; None if the line is not a firewire-ohci debug line."""
    if (match := PACKET.search(line)) is not None:
        return [_packet(match, time_ns, state)]
    if (match := BUS_RESET.search(line)) is not None:
        return _bus_reset(int(match["gen"]), time_ns, state)
    if (match := SELF_IDS.search(line)) is not None:
        state.local = phy_of(int(match["id"], 16))
        return _bus_reset(int(match["gen"]), time_ns, state)
    if (match := SELF_ID.search(line)) is not None:
        quadlet = int(match["q"], 16)
        raw = struct.pack(">I", quadlet)
        return [
            BusRecord(
                time_ns,
                RecordType.phy_packet,
                raw,
                state.generation,
                sender=SELF_ID_PHY((quadlet,)),
                speed=SPEED_UNKNOWN,
                crc_present=False,
                direction=Direction.inbound,
                observer=state.local,
            )
        ]
    if (match := PHY.search(line)) is not None:
        raw = struct.pack(">II", int(match["q"], 16), int(match["inv"], 16))
        direction = Direction.outbound if match["dir"] == "T" else Direction.inbound
        ack = ACKS.get(match["evt"].strip())
        return [
            BusRecord(
                time_ns,
                RecordType.phy_packet,
                raw,
                state.generation,
                ack=ack,
                direction=direction,
                observer=state.local,
            )
        ]
    if STREAM.search(line):
        return []  # the driver printed nothing of a stream packet but its kind
    return None


#: The card's generation is a C unsigned int in the kernel.
MAX_GENERATION = 0xFFFFFFFF
#: Speed codes OHCI prints (S100 to S3200 and the reserved ones of its 3-bit field).
MAX_SPEED = 7


def _speed(digits: str) -> int:
    speed = int(digits)
    if speed > MAX_SPEED:
        raise ValueError(f"speed code {speed} is not one of OHCI's (0-{MAX_SPEED})")
    return speed


def _bus_reset(generation: int, time_ns: int, state: OhciState) -> list[BusRecord]:
    # Both the AR bus-reset event and the self-ID summary announce a reset: keep one.
    if generation > MAX_GENERATION:
        raise ValueError(f"generation {generation} is beyond the kernel's 32 bits")
    state.generation = generation
    if generation in state.announced:
        return []
    state.announced = {generation}
    return [BusRecord(time_ns, RecordType.bus_reset, b"", generation, observer=state.local)]


def _packet(match: re.Match[str], time_ns: int, state: OhciState) -> BusRecord:
    tcode = TCODE_NAMES.get(match["tname"].strip())
    source, destination = int(match["src"], 16), int(match["dst"], 16)
    if tcode is None:
        raise ValueError(f"unknown tcode name {match['tname']!r}")
    layout = LAYOUTS[tcode]
    # Fields the line does not print stay 0; the layout places the ones it does.
    fields = dict.fromkeys(layout.header.names, 0)
    fields |= {"destination_id": destination, "source_id": source, "tcode": tcode}
    fields["tlabel"] = int(match["tl"], 16)
    if match["addr"]:
        fields["offset"] = int(match["addr"], 16)
    specific = (match["specific"] or "").strip()
    if specific.startswith("="):
        fields["quadlet_data"] = int(specific[1:], 16)
    elif specific:
        fields["data_length"], fields["extended_tcode"] = (
            int(part, 16) for part in specific.split(",")
        )
    raw = layout.header.format.pack(*layout.header.pack_fields(fields))
    direction = Direction.outbound if match["dir"] == "T" else Direction.inbound
    event = match["evt"].strip()
    ack = ACKS.get(event, 0 if event == "evt_missing_ack" else None)
    local = source if direction == Direction.outbound else destination
    return BusRecord(
        time_ns,
        RecordType.async_packet,
        raw,
        state.generation,
        sender=phy_of(source),
        speed=_speed(match["spd"]),
        ack=ack,
        crc_present=False,
        direction=direction,
        observer=phy_of(local),
        partial=True,
    )
