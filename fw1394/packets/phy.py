"""PHY packets: one quadlet followed by its bitwise complement, no CRC.

Layouts are :class:`~fw1394.packets.fields.Quadlets` like the asynchronous ones;
which layout applies is decided by the identifier bits (31..30), the extended
bit of self-ID packets (23), and for identifier 0 the R/T bits and the 1394a
``type`` field (21..18).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass, fields, replace
from typing import Any, ClassVar, Self

from fw1394.packets.enums import PortStatus
from fw1394.packets.errors import PacketError
from fw1394.packets.fields import FieldRangeError, FieldSpec, Quadlets, out_of_range

_PAIR = struct.Struct(">II")
_MASK32 = 0xFFFFFFFF

SELF_ID_ZERO: tuple[FieldSpec, ...] = (
    ("identifier", 2),
    ("phy_id", 6),
    ("extended", 1),
    ("link_active", 1),
    ("gap_count", 6),
    ("scode", 2),
    ("phy_delay", 2),
    ("contender", 1),
    ("power_class", 3),
    ("port0", 2),
    ("port1", 2),
    ("port2", 2),
    ("initiated_reset", 1),
    ("more_packets", 1),
)
SELF_ID_EXTENDED: tuple[FieldSpec, ...] = (
    ("identifier", 2),
    ("phy_id", 6),
    ("extended", 1),
    ("sequence", 3),
    ("reserved", 2, 1),
    *((f"port{letter}", 2) for letter in "abcdefgh"),
    ("reserved", 1),
    ("more_packets", 1),
)
PHY_CONFIG: tuple[FieldSpec, ...] = (
    ("identifier", 2),
    ("root_id", 6),
    ("force_root", 1),
    ("gap_count_optimization", 1),
    ("gap_count", 6),
    ("reserved", 16),
)
LINK_ON: tuple[FieldSpec, ...] = (("identifier", 2), ("phy_id", 6), ("reserved", 24))
#: 1394a extended PHY packets: identifier 0 with R = T = 0 and a type.
EXTENDED_HEAD: tuple[FieldSpec, ...] = (
    ("identifier", 2),
    ("phy_id", 6),
    ("force_root", 1),
    ("gap_count_optimization", 1),
    ("type", 4),
)
PLAIN_EXTENDED = (*EXTENDED_HEAD, ("reserved", 18))
REMOTE_ACCESS = (*EXTENDED_HEAD, ("page", 3), ("port", 4), ("register", 3), ("reserved", 8))
REMOTE_REPLY = (*EXTENDED_HEAD, ("page", 3), ("port", 4), ("register", 3), ("value", 8))
REMOTE_COMMAND = (
    *EXTENDED_HEAD,
    ("reserved", 3, 8),
    ("port", 4),
    ("reserved", 8),
    ("command", 3),
)
REMOTE_CONFIRMATION = (
    *EXTENDED_HEAD,
    ("reserved", 3, 3),
    ("port", 4),
    ("reserved", 3),
    ("fault", 1),
    ("connected", 1),
    ("bias", 1),
    ("disabled", 1),
    ("ok", 1),
    ("command", 3),
)


@dataclass(frozen=True, slots=True, kw_only=True)
class PhyPacket:
    """Common part of PHY packets. ``inverse`` is the check quadlet as received.

    ``phy_id`` is the sender's PHY ID; PHY configuration packets carry a
    ``root_id`` instead and leave it 0.
    """

    LAYOUT: ClassVar[Quadlets]
    NAME: ClassVar[str]
    #: Fixed field values that select this kind (identifier, extended, type).
    SELECTOR: ClassVar[dict[str, int]]
    phy_id: int = 0
    inverse: int | None = None
    trailing: bytes = b""

    @property
    def kind(self) -> str:
        return self.NAME

    def field_values(self) -> dict[str, int]:
        values = {
            name: int(getattr(self, name)) for name in self.LAYOUT.names if hasattr(self, name)
        }
        return values | self.SELECTOR

    @property
    def quadlet(self) -> int:
        try:
            (value,) = self.LAYOUT.pack_fields(self.field_values())
        except KeyError as missing:
            raise PacketError(str(missing), "missing") from None
        return int(value)

    @property
    def inverse_ok(self) -> bool | None:
        return None if self.inverse is None else self.inverse == self.quadlet ^ _MASK32

    def with_inverse(self) -> Self:
        return replace(self, inverse=self.quadlet ^ _MASK32)

    @property
    def problems(self) -> tuple[PacketError, ...]:
        found = []
        if self.inverse is not None and not self.inverse_ok:
            found.append(
                PacketError(
                    "inverse",
                    f"{self.inverse:#010x} is not the complement of {self.quadlet:#010x}",
                )
            )
        if self.trailing:
            found.append(
                PacketError("length", f"{len(self.trailing)} bytes follow the end of the packet")
            )
        return tuple(found)


@dataclass(frozen=True, slots=True, kw_only=True)
class SelfIdPacket(PhyPacket):
    """Self-ID packet #0: a node's PHY ID, link and gap state, speed and ports 0-2."""

    LAYOUT = Quadlets(SELF_ID_ZERO)
    NAME = "self_id"
    SELECTOR = {"identifier": 2, "extended": 0}
    link_active: bool = False
    gap_count: int = 0
    scode: int = 0
    phy_delay: int = 0
    contender: bool = False
    power_class: int = 0
    port0: int = PortStatus.none
    port1: int = PortStatus.none
    port2: int = PortStatus.none
    initiated_reset: bool = False
    more_packets: bool = False

    @property
    def port_status(self) -> tuple[int, ...]:
        return (self.port0, self.port1, self.port2)


@dataclass(frozen=True, slots=True, kw_only=True)
class ExtendedSelfIdPacket(PhyPacket):
    """Self-ID packet #1..#3 (``sequence`` 0..2): eight more ports each."""

    LAYOUT = Quadlets(SELF_ID_EXTENDED)
    NAME = "self_id_extended"
    SELECTOR = {"identifier": 2, "extended": 1}
    sequence: int = 0
    porta: int = 0
    portb: int = 0
    portc: int = 0
    portd: int = 0
    porte: int = 0
    portf: int = 0
    portg: int = 0
    porth: int = 0
    reserved: int = 0
    more_packets: bool = False

    @property
    def port_status(self) -> tuple[int, ...]:
        return tuple(getattr(self, f"port{letter}") for letter in "abcdefgh")


@dataclass(frozen=True, slots=True, kw_only=True)
class PhyConfigPacket(PhyPacket):
    """PHY configuration: force a root (R) and/or set every PHY's gap count (T)."""

    LAYOUT = Quadlets(PHY_CONFIG)
    NAME = "phy_config"
    SELECTOR = {"identifier": 0}
    root_id: int = 0
    force_root: bool = False
    # With neither R nor T set the quadlet would be a 1394a extended PHY packet,
    # so the default sets the gap count (to 63, its value after a bus reset).
    gap_count_optimization: bool = True
    gap_count: int = 63  # not a node ID: the gap count a bus reset leaves
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class LinkOnPacket(PhyPacket):
    """Link-on PHY packet: wakes the link of node ``phy_id``."""

    LAYOUT = Quadlets(LINK_ON)
    NAME = "link_on"
    SELECTOR = {"identifier": 1}
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class PingPacket(PhyPacket):
    """Ping: the addressed PHY answers with its self-ID packets (1394a)."""

    LAYOUT = Quadlets(PLAIN_EXTENDED)
    NAME = "ping"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0, "type": 0x0}
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class ResumePacket(PhyPacket):
    """Resume: every suspended port of the sender's PHY is to resume (1394a)."""

    LAYOUT = Quadlets(PLAIN_EXTENDED)
    NAME = "resume"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0, "type": 0xF}
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class RemoteAccessPacket(PhyPacket):
    """Remote access: read a PHY register of another node (type 1 base, 5 paged)."""

    LAYOUT = Quadlets(REMOTE_ACCESS)
    NAME = "remote_access"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0}
    type: int = 0x1
    page: int = 0
    port: int = 0
    register: int = 0
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class RemoteReplyPacket(PhyPacket):
    """Remote reply: the register value asked for by a remote access (type 3 or 7)."""

    LAYOUT = Quadlets(REMOTE_REPLY)
    NAME = "remote_reply"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0}
    type: int = 0x3
    page: int = 0
    port: int = 0
    register: int = 0
    value: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class RemoteCommandPacket(PhyPacket):
    """Remote command PHY packet: a command to one port of a remote PHY."""

    LAYOUT = Quadlets(REMOTE_COMMAND)
    NAME = "remote_command"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0, "type": 0x8}
    port: int = 0
    command: int = 0
    reserved: int = 0


@dataclass(frozen=True, slots=True, kw_only=True)
class RemoteConfirmationPacket(PhyPacket):
    """Remote confirmation PHY packet: a remote PHY's answer to a command."""

    LAYOUT = Quadlets(REMOTE_CONFIRMATION)
    NAME = "remote_confirmation"
    SELECTOR = {"identifier": 0, "force_root": 0, "gap_count_optimization": 0, "type": 0xA}
    port: int = 0
    fault: bool = False
    connected: bool = False
    bias: bool = False
    disabled: bool = False
    ok: bool = False
    command: int = 0
    reserved: int = 0


PHY_CLASSES: tuple[type[PhyPacket], ...] = (
    SelfIdPacket,
    ExtendedSelfIdPacket,
    PhyConfigPacket,
    LinkOnPacket,
    PingPacket,
    ResumePacket,
    RemoteAccessPacket,
    RemoteReplyPacket,
    RemoteCommandPacket,
    RemoteConfirmationPacket,
)
_FLAGS: dict[type[PhyPacket], tuple[str, ...]] = {
    cls: tuple(f.name for f in fields(cls) if f.type == "bool") for cls in PHY_CLASSES
}
_EXTENDED_TYPES: dict[int, type[PhyPacket]] = {
    0x0: PingPacket,
    0x1: RemoteAccessPacket,
    0x5: RemoteAccessPacket,
    0x3: RemoteReplyPacket,
    0x7: RemoteReplyPacket,
    0x8: RemoteCommandPacket,
    0xA: RemoteConfirmationPacket,
    0xF: ResumePacket,
}


def phy_class_of(quadlet: int) -> type[PhyPacket]:
    """Which PHY packet kind a first quadlet is."""
    identifier = quadlet >> 30
    if identifier == 2:
        return ExtendedSelfIdPacket if quadlet >> 23 & 1 else SelfIdPacket
    if identifier == 1:
        return LinkOnPacket
    if identifier == 0 and not quadlet >> 22 & 3:
        # R = T = 0: a 1394a extended PHY packet; unknown types stay PHY configuration.
        return _EXTENDED_TYPES.get(quadlet >> 18 & 0xF, PhyConfigPacket)
    if identifier == 0:
        return PhyConfigPacket
    raise PacketError("identifier", "3 is not a PHY packet identifier")


def decode_phy(raw: bytes, *, inverse: bool = True) -> PhyPacket:
    """Decode a PHY packet: its quadlet, then (``inverse=True``) the check quadlet."""
    need = 8 if inverse else 4
    if len(raw) < need:
        raise PacketError(
            "length", f"{len(raw)} bytes is too short for a PHY packet ({need} bytes)"
        )
    quadlet = int.from_bytes(raw[:4], "big")
    cls = phy_class_of(quadlet)
    values: dict[str, Any] = cls.LAYOUT.unpack_fields(raw[:4])
    for name in cls.SELECTOR:
        del values[name]
    for name in _FLAGS[cls]:
        values[name] = bool(values[name])
    check = int.from_bytes(raw[4:8], "big") if inverse else None
    return cls(**values, inverse=check, trailing=raw[need:])


def encode_phy(packet: PhyPacket, *, inverse: bool = True) -> bytes:
    """The quadlet and (``inverse=True``) its check quadlet, as given or computed."""
    try:
        quadlet = packet.quadlet
        for name, value in packet.field_values().items():
            width = packet.LAYOUT.widths[name]
            if not 0 <= value < 1 << width:
                raise FieldRangeError(name, out_of_range(value, width))
    except FieldRangeError as error:
        raise PacketError(error.field, error.problem) from None
    if not inverse:
        return quadlet.to_bytes(4, "big") + packet.trailing
    check = packet.inverse if packet.inverse is not None else quadlet ^ _MASK32
    return _PAIR.pack(quadlet, check) + packet.trailing


def self_id_port_status(packets: list[PhyPacket]) -> list[int]:
    """Port statuses of one node's self-ID sequence, port 0 first."""
    ports: list[int] = []
    for packet in packets:
        if isinstance(packet, SelfIdPacket | ExtendedSelfIdPacket):
            ports.extend(packet.port_status)
    return ports
