"""The bus's frames: what the header's fields mean, and the bus-management payloads.

A frame is a header and a payload that depends on the header's kind. The
header is described once, in :mod:`fw1394.packets.frame`; the struct formats,
the size and the offsets the kernel socket filter
(:mod:`fw1394.transport.media.bpf`) reads in place are derived from it here.
This module adds what the header's fields mean to the bus (:class:`FrameKind`,
the special physical IDs) and the bus-management payloads;
``docs/virtual-bus.md`` lists every kind's payload byte by byte.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum
from typing import NamedTuple

from fw1394.errors import PacketError
from fw1394.packets import Speed
from fw1394.packets.ack import ack_byte as ack_byte  # re-exported: bus members use it
from fw1394.packets.ack import ack_code
from fw1394.packets.frame import (
    ACK_FRAME_FORMAT,
    FRAME_HEADER_FORMAT,
    FRAME_HEADER_OFFSETS,
    FRAME_HEADER_SIZE,
    FRAME_HEADER_VALUES,
    FRAME_MAGIC,
    FRAME_PREFIX,
    FRAME_VERSION,
)
from fw1394.packets.nodeid import BROADCAST_PHY as BROADCAST_PHY  # re-exported
from fw1394.packets.nodeid import MAX_NODES

MAGIC = FRAME_MAGIC
VERSION = FRAME_VERSION
HEADER = FRAME_HEADER_FORMAT
HEADER_SIZE = FRAME_HEADER_SIZE
#: The header's fields from ``kind`` on, in :class:`FrameHeader` order (prefix and
#: reserved byte skipped), and the bytes every frame starts with: for receivers
#: that check the prefix and unpack the rest in one step.
HEADER_VALUES = FRAME_HEADER_VALUES
HEADER_PREFIX = FRAME_PREFIX
NO_PHY = 0xFF
EVERY_MEMBER = 0xFF
#: Offsets the socket filter reads (relative to the UDP payload).
KIND_OFFSET = FRAME_HEADER_OFFSETS["kind"]
TAG_OFFSET = FRAME_HEADER_OFFSETS["tag"]
SENDER_OFFSET = FRAME_HEADER_OFFSETS["sender"]
DESTINATION_OFFSET = FRAME_HEADER_OFFSETS["destination"]
#: 63 physical IDs (0-62): node 63 is the broadcast address.
MAX_MEMBERS = MAX_NODES
#: The largest UDP payload IPv4 can carry (65,535 minus the IP and UDP headers):
#: one frame is one datagram, so this bounds every frame.
MAX_UDP_PAYLOAD = 65_507


class FrameKind(IntEnum):
    """What a frame carries."""

    async_packet = 1  # an asynchronous packet with CRCs
    ack = 2  # an ack, optionally followed by a concatenated response
    phy_packet = 3  # a PHY packet and its check quadlet (self-IDs included)
    join = 16  # a process asks to be on the bus
    leave = 17  # a member leaves cleanly
    heartbeat = 18  # a member is alive (to the coordinator)
    beacon = 19  # the coordinator is alive; the member table
    bus_reset = 20  # a new generation and its members in physical-ID order
    reset_request = 21  # someone asks the coordinator for a bus reset
    refused = 22  # the coordinator turns a joiner away (the bus is full)


CONTROL_KINDS = frozenset(
    {
        FrameKind.join,
        FrameKind.leave,
        FrameKind.heartbeat,
        FrameKind.beacon,
        FrameKind.bus_reset,
        FrameKind.reset_request,
        FrameKind.refused,
    }
)


class FrameError(PacketError):
    """Bytes that are not a frame of this bus."""


class FrameTooLarge(PacketError):
    """A frame that does not fit one datagram: the tunnel cannot carry it."""

    def __init__(self, size: int) -> None:
        self.size = size
        limit = MAX_UDP_PAYLOAD
        super().__init__(f"a frame of {size} bytes exceeds the {limit}-byte datagram limit")


class FrameHeader(NamedTuple):
    """A parsed frame header (a tuple: it is made for every frame received)."""

    kind: int
    tag: int
    sender: int
    generation: int
    sender_phy: int
    destination: int
    speed: int = Speed.S400
    sequence: int = 0

    def pack(self) -> bytes:
        return HEADER.pack(
            MAGIC,
            VERSION,
            self.kind,
            self.tag,
            self.sender,
            self.generation & 0xFFFFFFFF,
            self.sender_phy,
            self.destination,
            self.speed,
            0,
            self.sequence & 0xFFFFFFFF,
        )


def parse_header(frame: bytes) -> FrameHeader:
    if len(frame) < HEADER_SIZE:
        raise FrameError(f"{len(frame)} bytes is shorter than a frame header")
    magic, version, kind, tag, sender, generation, sphy, dest, speed, _, seq = HEADER.unpack_from(
        frame
    )
    if magic != MAGIC or version != VERSION:
        raise FrameError(f"not an fw1394 v{VERSION} frame (magic {magic:#06x} v{version})")
    return FrameHeader(kind, tag, sender, generation, sphy, dest, speed, seq)


# -- ack payload ------------------------------------------------------------------------
#: ack byte (code and parity as on the wire), tlabel of the acknowledged packet,
#: reserved u16, sequence number of the acknowledged frame.
ACK_PAYLOAD = ACK_FRAME_FORMAT


@dataclass(frozen=True, slots=True)
class AckPayload:
    ack_byte: int
    tlabel: int
    acked_sequence: int
    #: A response sent in the same bus tenure (concatenated), or empty.
    concatenated: bytes = b""

    @property
    def code(self) -> int:
        return ack_code(self.ack_byte)

    def pack(self) -> bytes:
        return (
            ACK_PAYLOAD.pack(self.ack_byte, self.tlabel, 0, self.acked_sequence) + self.concatenated
        )


def parse_ack(payload: bytes) -> AckPayload:
    if len(payload) < ACK_PAYLOAD.size:
        raise FrameError(f"ack payload of {len(payload)} bytes is too short")
    byte, tlabel, _, sequence = ACK_PAYLOAD.unpack_from(payload)
    return AckPayload(byte, tlabel, sequence, payload[ACK_PAYLOAD.size :])


# -- member table -----------------------------------------------------------------------
#: member id, rank, flags, board id, PID namespace tag, pid, IPv4 address of its interface.
MEMBER = struct.Struct(">IQBBHI4s")
FLAG_CONTENDER = 0x01
FLAG_HOST = 0x02
NO_BOARD = 0xFF


@dataclass(frozen=True, slots=True)
class MemberInfo:
    """What a member says about itself when it joins.

    Physical IDs follow the sort key (contender, rank, member id): boards (not
    contenders) first in rank order, then hosts, so that a host joining or
    leaving never renumbers the boards and the host ends up root, as a PC's
    cycle-master-capable link usually does.
    """

    member_id: int
    rank: int
    contender: bool = False
    host: bool = False
    board_id: int = NO_BOARD
    pid: int = 0
    address: str = "127.0.0.1"
    #: 16 bits of the PID namespace: a pid means something only to its namespace.
    pid_namespace: int = 0

    @property
    def sort_key(self) -> tuple[bool, int, int]:
        return (self.contender, self.rank, self.member_id)

    def pack(self) -> bytes:
        flags = (FLAG_CONTENDER if self.contender else 0) | (FLAG_HOST if self.host else 0)
        return MEMBER.pack(
            self.member_id,
            self.rank,
            flags,
            self.board_id,
            self.pid_namespace,
            self.pid,
            bytes(int(part) for part in self.address.split(".")),
        )


def parse_member(payload: bytes, offset: int = 0) -> MemberInfo:
    member_id, rank, flags, board, namespace, pid, address = MEMBER.unpack_from(payload, offset)
    return MemberInfo(
        member_id,
        rank,
        bool(flags & FLAG_CONTENDER),
        bool(flags & FLAG_HOST),
        board,
        pid,
        ".".join(str(b) for b in address),
        namespace,
    )


#: initiator member id (0: none), count, reserved; then ``count`` members.
TABLE = struct.Struct(">IHH")


def pack_table(members: tuple[MemberInfo, ...], initiator: int = 0) -> bytes:
    return TABLE.pack(initiator, len(members), 0) + b"".join(m.pack() for m in members)


def parse_table(payload: bytes) -> tuple[int, tuple[MemberInfo, ...]]:
    """Initiator and members of a beacon or bus-reset payload."""
    if len(payload) < TABLE.size:
        raise FrameError("member table is too short")
    initiator, count, _ = TABLE.unpack_from(payload)
    if count > MAX_MEMBERS or len(payload) < TABLE.size + count * MEMBER.size:
        raise FrameError(f"member table of {count} entries does not fit {len(payload)} bytes")
    members = tuple(parse_member(payload, TABLE.size + i * MEMBER.size) for i in range(count))
    return initiator, members


#: A join: the member's table entry, then the member id of the coordinator it asks
#: (0: whichever coordinator hears it).
JOIN_TARGET = struct.Struct(">I")


def pack_join(info: MemberInfo, coordinator: int) -> bytes:
    return info.pack() + JOIN_TARGET.pack(coordinator)


def parse_join(payload: bytes) -> tuple[MemberInfo, int]:
    if len(payload) < MEMBER.size + JOIN_TARGET.size:
        raise FrameError("join payload is too short")
    (target,) = JOIN_TARGET.unpack_from(payload, MEMBER.size)
    return parse_member(payload), target


def pack_refusal(member_id: int, reason: str) -> bytes:
    return JOIN_TARGET.pack(member_id) + reason.encode()


def parse_refusal(payload: bytes) -> tuple[int, str]:
    if len(payload) < JOIN_TARGET.size:
        raise FrameError("refusal payload is too short")
    (member_id,) = JOIN_TARGET.unpack_from(payload)
    return member_id, payload[JOIN_TARGET.size :].decode(errors="replace")
