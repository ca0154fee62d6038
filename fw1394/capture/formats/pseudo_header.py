"""The fw1394 link layer: a 12-byte pseudo-header in front of the wire quadlets.

pcap has no link type for raw IEEE 1394 packets, so fw1394 traces use a
private LINKTYPE_USER slot. Each captured packet is this pseudo-header
followed by the packet exactly as it travelled (big-endian quadlets, CRC
quadlets included when :attr:`Flags.crc_present`). ``docs/capture-format.md``
describes it byte by byte; this module is its only definition, and the Lua
dissector, the scapy layer and the numpy reader all read positions from
:data:`PSEUDO_HEADER`.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from construct import BitsInteger, BitStruct, Flag, Int8ub, Int16ub, Struct

from fw1394.capture.formats.record import SPEED_UNKNOWN, BusRecord, Direction, RecordType
from fw1394.packets.ack import ACK_CODE_MASK
from fw1394.packets.bitfields import BitField, flatten, struct_format
from fw1394.packets.nodeid import phy_of

#: LINKTYPE_USER0; Wireshark's Lua dissector binds to the same slot.
LINKTYPE_FW1394 = 147
VERSION = 1
#: Value of the sender and observer bytes when there is no such node.
NO_NODE = 0xFF

FLAGS = BitStruct(
    "reserved" / BitsInteger(8),
    "time_unknown" / Flag,  # the source had no clock: timestamps only order records
    "partial" / Flag,  # rebuilt from a log line: rcode, retry, priority, data unknown
    "direction" / BitsInteger(2),  # a Direction value
    "ack_present" / Flag,  # the ack byte holds the ack that followed the packet
    "crc_placeholder" / Flag,  # CRC quadlets present but never computed: do not check
    "crc_valid" / Flag,  # every CRC (or PHY check quadlet) matched when written
    "crc_present" / Flag,  # the packet includes its CRC (or PHY check) quadlets
)
PSEUDO_HEADER = Struct(
    "version" / Int8ub,
    "header_length" / Int8ub,  # bytes before the packet; readers skip this many
    "record_type" / Int8ub,  # a RecordType value
    "speed" / Int8ub,  # 0..3 = S100..S800, 0xFF unknown
    "flags" / FLAGS,
    "ack" / Int8ub,  # ack code (low 4 bits) when flags.ack_present
    "generation" / Int8ub,  # bus generation the packet belongs to
    "sender" / Int8ub,  # physical ID of the transmitting node, 0xFF unknown
    "observer" / Int8ub,  # physical ID of the logging node, 0xFF for a passive tap
    "reserved" / Int16ub,
)
HEADER_LENGTH = PSEUDO_HEADER.sizeof()
FIELDS: dict[str, BitField] = {field.name: field for field in flatten(PSEUDO_HEADER)}
#: The one-bit and small flags, in the order of the flags word (Wireshark: ph.flags.NAME).
FLAG_NAMES = tuple(name.removeprefix("flags.") for name in FIELDS if name.startswith("flags."))
_PACKER = struct.Struct(struct_format(PSEUDO_HEADER))


def flag_bit(name: str) -> int:
    """Mask of the one-bit flag ``name`` inside the 16-bit flags word."""
    field = FIELDS[f"flags.{name}"]
    return field.mask << field.lsb


def flag_value(flags: int, name: str) -> int:
    field = FIELDS[f"flags.{name}"]
    return (flags >> field.lsb) & field.mask


@dataclass(frozen=True)
class PseudoHeader:
    """The decoded pseudo-header of one captured packet."""

    record_type: int
    speed: int
    flags: int
    ack: int
    generation: int
    sender: int
    observer: int
    version: int = VERSION
    header_length: int = HEADER_LENGTH

    def flag(self, name: str) -> int:
        return flag_value(self.flags, name)


# Bits of the flags word, looked up once: encode_flags runs for every captured packet.
_DIRECTION_SHIFT = FIELDS["flags.direction"].lsb
_CRC_PRESENT, _CRC_VALID, _CRC_PLACEHOLDER, _ACK_PRESENT, _PARTIAL, _TIME_UNKNOWN = (
    flag_bit(name)
    for name in (
        "crc_present",
        "crc_valid",
        "crc_placeholder",
        "ack_present",
        "partial",
        "time_unknown",
    )
)


def encode_flags(record: BusRecord, crc_valid: bool) -> int:
    flags = int(record.direction) << _DIRECTION_SHIFT
    if record.crc_present:
        flags |= _CRC_PRESENT
        if crc_valid and not record.crc_placeholder:
            flags |= _CRC_VALID
    if record.crc_placeholder:
        flags |= _CRC_PLACEHOLDER
    if record.ack is not None:
        flags |= _ACK_PRESENT
    if record.partial:
        flags |= _PARTIAL
    if not record.time_known:
        flags |= _TIME_UNKNOWN
    return flags


def encode(record: BusRecord, crc_valid: bool) -> bytes:
    """Pseudo-header bytes for ``record``; ``crc_valid`` as the caller checked it."""
    return _PACKER.pack(
        VERSION,
        HEADER_LENGTH,
        int(record.record_type),
        record.speed & 0xFF,
        encode_flags(record, crc_valid),
        (record.ack or 0) & ACK_CODE_MASK,
        record.generation & 0xFF,
        NO_NODE if record.sender is None else phy_of(record.sender),
        NO_NODE if record.observer is None else phy_of(record.observer),
        0,
    )


def decode(raw: bytes) -> PseudoHeader:
    """Parse the pseudo-header at the start of ``raw`` (``ValueError`` if unusable)."""
    if len(raw) < 2:
        raise ValueError(f"{len(raw)} bytes cannot hold a pseudo-header")
    if raw[0] != VERSION:
        raise ValueError(f"pseudo-header version {raw[0]} is not {VERSION}")
    if raw[1] < HEADER_LENGTH or len(raw) < raw[1]:
        raise ValueError(f"pseudo-header length {raw[1]} does not fit a {len(raw)}-byte record")
    version, length, kind, speed, flags, ack, generation, sender, observer, _ = _PACKER.unpack_from(
        raw
    )
    return PseudoHeader(kind, speed, flags, ack, generation, sender, observer, version, length)


def to_record(header: PseudoHeader, packet: bytes, timestamp_ns: int) -> BusRecord:
    """A :class:`BusRecord` from a decoded pseudo-header and the packet after it."""
    try:
        kind = RecordType(header.record_type)
    except ValueError:
        raise ValueError(f"unknown record type {header.record_type}") from None
    try:
        direction = Direction(header.flag("direction"))
    except ValueError:
        direction = Direction.bus
    return BusRecord(
        timestamp_ns=timestamp_ns,
        record_type=kind,
        data=packet,
        generation=header.generation,
        sender=None if header.sender == NO_NODE else header.sender,
        speed=header.speed if header.speed <= 3 else SPEED_UNKNOWN,
        ack=header.ack if header.flag("ack_present") else None,
        crc_present=bool(header.flag("crc_present")),
        direction=direction,
        observer=None if header.observer == NO_NODE else header.observer,
        crc_placeholder=bool(header.flag("crc_placeholder")),
        partial=bool(header.flag("partial")),
        time_known=not header.flag("time_unknown"),
    )
