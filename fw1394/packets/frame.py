"""The virtual bus's frame header and ack payload, described once as construct structs.

One UDP datagram carries one frame: a fixed header, then a payload that
depends on the frame's kind. The transport packs millions of these, so it
uses :mod:`struct` formats; those formats, the header size and the byte
offsets the kernel socket filter reads are all derived here from the
construct descriptions, never written down a second time.
"""

from __future__ import annotations

import struct

from construct import Bytes, Const, Default, Int8ub, Int16ub, Int32ub, Int64ub, Struct

from fw1394.packets.bitfields import flatten, struct_format

#: "FW": the first two bytes of every frame.
FRAME_MAGIC = 0x4657
FRAME_VERSION = 1

FRAME_HEADER = Struct(
    "magic" / Const(FRAME_MAGIC, Int16ub),
    "version" / Const(FRAME_VERSION, Int8ub),
    "kind" / Int8ub,
    "tag" / Int32ub,  # from the bus name: frames of other buses are dropped
    "sender" / Int32ub,  # member id, random per process, never 0
    "generation" / Int32ub,
    "sender_phy" / Int8ub,  # 0xFF before the sender's first self-ID phase
    "destination" / Int8ub,  # physical ID, 63 broadcast, 0xFF every member
    "speed" / Int8ub,
    # Read as whatever arrives, written as 0: a later version may use it.
    "reserved" / Default(Int8ub, 0),
    "sequence" / Int32ub,  # per sender, wraps; acks name the frame by it
)

#: Bytes of the keyed MAC that ends a sealed frame.
FRAME_MAC_SIZE = 16

#: What every frame of a keyed bus ends with, behind its payload: a trailer, so
#: that the header and every offset the kernel filter reads stay where they are.
FRAME_TRAILER = Struct(
    # Per sender, one more for every datagram it sends (a copy too): the receivers'
    # replay window reads it. 64 bits never wrap.
    "counter" / Int64ub,
    # BLAKE2s keyed with the bus key over everything before it, counter included.
    "mac" / Bytes(FRAME_MAC_SIZE),
)

#: The payload of an ack frame; a concatenated response may follow it.
ACK_FRAME = Struct(
    "ack_byte" / Int8ub,  # code and parity, laid out as fw1394.packets.ack.ACK_LAYOUT
    "tlabel" / Int8ub,  # of the acknowledged packet
    "reserved" / Default(Int16ub, 0),
    "acked_sequence" / Int32ub,
)


def field_spans(layout: Struct) -> dict[str, tuple[int, int]]:
    """Byte offset and size of every field of a flat, byte-aligned ``layout``."""
    return {f.name: (f.byte_offset, f.byte_size) for f in flatten(layout)}


def field_offsets(layout: Struct) -> dict[str, int]:
    """Byte offset of every field of a flat, byte-aligned ``layout``."""
    return {name: offset for name, (offset, _) in field_spans(layout).items()}


def constant_prefix(layout: Struct) -> bytes:
    """The bytes of the constant fields a ``layout`` starts with."""
    prefix = b""
    for subcon in layout.subcons:
        if not isinstance(subcon.subcon, Const):
            break
        prefix += subcon.build(None)
    return prefix


#: Every header field, reserved byte included (written as 0).
FRAME_HEADER_FORMAT = struct.Struct(struct_format(FRAME_HEADER))
#: The header's variable fields only, in order (the prefix and reserved byte skipped).
FRAME_HEADER_VALUES = struct.Struct(
    struct_format(FRAME_HEADER, frozenset({"magic", "version", "reserved"}))
)
FRAME_HEADER_SIZE = FRAME_HEADER.sizeof()
FRAME_HEADER_OFFSETS = field_offsets(FRAME_HEADER)
FRAME_HEADER_SPANS = field_spans(FRAME_HEADER)
#: Magic and version: what every frame of this version starts with.
FRAME_PREFIX = constant_prefix(FRAME_HEADER)

ACK_FRAME_FORMAT = struct.Struct(struct_format(ACK_FRAME))
ACK_FRAME_SIZE = ACK_FRAME.sizeof()

FRAME_TRAILER_SIZE = FRAME_TRAILER.sizeof()
#: The trailer's counter alone (the MAC is raw bytes, not a struct field).
FRAME_COUNTER_FORMAT = struct.Struct(struct_format(Struct(FRAME_TRAILER.subcons[0])))
