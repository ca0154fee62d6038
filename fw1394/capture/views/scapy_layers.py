"""scapy layers for IEEE 1394 packets, fw1394's link type and the JHU Eth1394 framing.

Every layer is generated from fw1394's definitions: packet fields from the
layouts' ``Quadlets.bitfields`` (named as the Linux kernel names them:
``dst_id``, ``src_id``), the pseudo-header and the Eth1394 control word and
extra bytes from their ``construct`` structs. Importing this module binds
the link type (LINKTYPE_USER0) and UDP port 1394, so::

    from scapy.all import rdpcap
    from fw1394.capture.views.scapy_layers import FW1394
    rdpcap("trace.pcapng")[0][FW1394].tlabel

scapy is needed only here; nothing else in fw1394 imports it.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path
from typing import Any, ClassVar, NamedTuple

from construct import Struct
from scapy.config import conf
from scapy.fields import BitField, StrLenField, XBitField
from scapy.layers.inet import UDP
from scapy.packet import Packet, Raw, bind_layers

from fw1394 import crc
from fw1394.capture.formats import pseudo_header
from fw1394.capture.formats.eth1394_udp import classify
from fw1394.capture.formats.record import RecordType
from fw1394.packets import LAYOUTS, PacketError
from fw1394.packets.accessors import DESTINATION_ID, TCODE
from fw1394.packets.ack import ACK_LAYOUT
from fw1394.packets.bitfields import BitField as LayoutBit
from fw1394.packets.bitfields import flatten
from fw1394.packets.eth1394 import CONTROL_WORD, EXTRA_BYTES, EXTRA_SIZE, UDP_PORT
from fw1394.packets.phy import PHY_CLASSES, phy_class_of
from fw1394.transport.sansio.config import DEFAULT_BUS

KERNEL_NAMES = {"destination_id": "dst_id", "source_id": "src_id"}
_HEX = {"dst_id", "src_id", "offset", "quadlet_data", "header_crc", "reserved"}


def _merged(bitfields: Iterable[LayoutBit]) -> list[tuple[str, int]]:
    """(name, width) in wire order; a field split over quadlets becomes one field.

    The split fields of asynchronous packets (the 48-bit offset, the reserved
    bits of responses) sit in consecutive bits, so one wide scapy field reads
    them whole; pieces apart from each other (reserved bits of PHY packets)
    get numbered names.
    """
    merged: list[tuple[str, int]] = []
    seen: dict[str, int] = {}
    for bit in bitfields:
        name = KERNEL_NAMES.get(bit.name, bit.name)
        if merged and merged[-1][0].partition("_part")[0] == name:
            merged[-1] = (merged[-1][0], merged[-1][1] + bit.width)
            continue
        seen[name] = seen.get(name, 0) + 1
        merged.append((name if seen[name] == 1 else f"{name}_part{seen[name]}", bit.width))
    return merged


#: Fields left None are worked out in post_build, as scapy does for lengths and
#: checksums: the CRCs, and a block's data_length from its data.
_COMPUTED = {"header_crc", "data_crc", "data_length"}


def _bit_fields(
    items: Iterable[tuple[str, int]], defaults: dict[str, int] | None = None
) -> list[Any]:
    fields: list[Any] = []
    for name, width in items:
        kind = XBitField if name in _HEX or name.endswith("_crc") else BitField
        default = (defaults or {}).get(name, 0)
        fields.append(kind(name, default, width))
    return fields


def _flat_fields(flat: Iterable[LayoutBit]) -> list[Any]:
    return _bit_fields((field.name.replace(".", "_"), field.width) for field in flat)


class FW1394(Packet):
    """Any asynchronous 1394 packet; ``pkt[FW1394]`` finds every kind below."""

    name = "IEEE 1394"
    match_subclass = True
    fields_desc: ClassVar[list[Any]] = []
    with_crc = True

    @classmethod
    def dispatch_hook(cls, _pkt: bytes | None = None, *args: Any, **kargs: Any) -> type[Packet]:
        if cls is FW1394 and _pkt and len(_pkt) >= TCODE.end:
            found = ASYNC_WITH_CRC.get(TCODE.of_bytes(_pkt))
            # A header cut short is bytes, not a packet (scapy's rule for a short layer).
            if found is None or len(_pkt) < found.header_bytes:
                return Raw
            return found
        return cls

    header_bytes: ClassVar[int] = 0
    header_quadlets: ClassVar[int] = 0
    data_length_at: ClassVar[int] = 0  # byte offset of the 16-bit data_length

    def post_build(self, packet: bytes, payload: bytes) -> bytes:
        """Fill in what was left None: data_length from the data, then the CRCs."""
        built = bytearray(packet)
        fields = {f.name for f in self.fields_desc}
        count = 4 * self.header_quadlets
        at = self.data_length_at
        if "data_length" in fields and self.data_length is None and "data" in fields:
            built[at : at + 2] = len(self.data or b"").to_bytes(2, "big")
        if "data" in fields:
            # Pad the data block to a quadlet boundary with zeros, as it travels.
            length = int.from_bytes(built[at : at + 2], "big")
            start = count + 4 * self.with_crc
            block = bytes(built[start : start + length])
            padding = bytes(-length % 4) if not self.padding else b""
            tail = built[start + length :]
            built = built[: start + length] + padding + tail
            if self.with_crc and self.data_crc is None:
                end = start + length + len(padding) + len(self.padding or b"")
                built[end : end + 4] = crc.data_crc(block).to_bytes(4, "big")
        if self.with_crc and "header_crc" in fields and self.header_crc is None:
            built[count : count + 4] = crc.header_crc(bytes(built[:count])).to_bytes(4, "big")
        return bytes(built) + payload


def _data_length(packet: Packet) -> int:
    return int(getattr(packet, "data_length", 0) or 0)


def _async_class(tcode: int, with_crc: bool) -> type[FW1394]:
    layout = LAYOUTS[tcode]  # type: ignore[index]
    header = layout.sealed_header if with_crc else layout.header
    # Each kind's own tcode is its default (as scapy's TCP has its proto); CRCs and
    # a block's length are computed at build time unless given.
    defaults: dict[str, Any] = {"tcode": tcode, "header_crc": None, "data_length": None}
    merged = _merged(header.bitfields)
    fields = _bit_fields(merged, defaults)
    bits = [width for _, width in merged]
    names = [name for name, _ in merged]
    length_at = sum(bits[: names.index("data_length")]) // 8 if "data_length" in names else 0
    if layout.has_data:
        fields.append(StrLenField("data", b"", length_from=_data_length))
        fields.append(StrLenField("padding", b"", length_from=lambda p: -_data_length(p) % 4))
        if with_crc:
            fields.append(XBitField("data_crc", None, 32))
    words = "".join(part.capitalize() for part in layout.name.split("_"))
    name = f"FW1394{words}" + ("" if with_crc else "NoCRC")
    namespace = {
        "name": f"IEEE 1394 {layout.name}",
        "fields_desc": fields,
        "with_crc": with_crc,
        "header_quadlets": layout.header.count,
        "header_bytes": 4 * header.count,
        "data_length_at": length_at,
    }
    return type(name, (FW1394,), namespace)


ASYNC_WITH_CRC = {int(t): _async_class(int(t), True) for t in LAYOUTS}
ASYNC_WITHOUT_CRC = {int(t): _async_class(int(t), False) for t in LAYOUTS}
#: Every kind by its class name (FW1394ReadQuadletRequest ...), importable from here.
globals().update({layer.__name__: layer for layer in ASYNC_WITH_CRC.values()})


class FW1394Phy(Packet):
    """A PHY packet (self-ID, PHY configuration, link-on, 1394a extended)."""

    name = "IEEE 1394 PHY packet"
    match_subclass = True
    fields_desc: ClassVar[list[Any]] = []

    @classmethod
    def dispatch_hook(cls, _pkt: bytes | None = None, *args: Any, **kargs: Any) -> type[Packet]:
        if cls is FW1394Phy and _pkt and len(_pkt) >= 4:
            try:
                return PHY_LAYERS[phy_class_of(int.from_bytes(_pkt[:4], "big")).NAME]
            except PacketError:
                return Raw
        return cls


def _phy_class(kind: Any) -> type[FW1394Phy]:
    fields = _bit_fields(_merged(kind.LAYOUT.bitfields))
    fields.append(XBitField("check", 0, 32))
    words = "".join(part.capitalize() for part in kind.NAME.split("_"))
    namespace = {"name": f"IEEE 1394 {kind.NAME}", "fields_desc": fields}
    return type(f"FW1394Phy{words}", (FW1394Phy,), namespace)


_PHY_KINDS = list(PHY_CLASSES.values()) if isinstance(PHY_CLASSES, dict) else list(PHY_CLASSES)
PHY_LAYERS = {kind.NAME: _phy_class(kind) for kind in _PHY_KINDS}


#: The ack byte's nibbles from its layout; the code is shown as ``ack``.
_ACK_NAMES = {"ack.code": "ack", "ack.parity": "parity"}


class FW1394Ack(Packet):
    name = "IEEE 1394 ack"
    fields_desc = _bit_fields(
        (_ACK_NAMES[field.name], field.width) for field in flatten(Struct("ack" / ACK_LAYOUT))
    )


class FW1394Capture(Packet):
    """fw1394's pseudo-header (docs/capture-format.md), then the packet."""

    name = "fw1394 pseudo-header"
    fields_desc = _flat_fields(flatten(pseudo_header.PSEUDO_HEADER))

    def extract_padding(self, s: bytes) -> tuple[bytes, bytes]:
        extra = max(int(self.header_length) - pseudo_header.HEADER_LENGTH, 0)
        return s[extra:], b""

    def guess_payload_class(self, payload: bytes) -> type[Packet]:
        kind = int(self.record_type)
        crc = bool(self.flags_crc_present)
        if kind == RecordType.async_packet and len(payload) >= TCODE.end:
            table = ASYNC_WITH_CRC if crc else ASYNC_WITHOUT_CRC
            return table.get(TCODE.of_bytes(payload), Raw)
        if kind == RecordType.phy_packet:
            return FW1394Phy
        if kind == RecordType.ack:
            return FW1394Ack
        return Raw


class Eth1394(Packet):
    """A JHU Eth1394 datagram: request or response, told apart by its content."""

    name = "Eth1394"
    match_subclass = True
    fields_desc: ClassVar[list[Any]] = []

    @classmethod
    def dispatch_hook(cls, _pkt: bytes | None = None, *args: Any, **kargs: Any) -> type[Packet]:
        if cls is not Eth1394 or not _pkt:
            return cls
        kind = classify(bytes(_pkt))
        if kind == "request":
            return Eth1394Request
        if kind in ("response", "extra_only"):
            return Eth1394Response
        return Raw


class Eth1394Request(Eth1394):
    name = "Eth1394 request"
    fields_desc = _flat_fields(flatten(CONTROL_WORD))

    def guess_payload_class(self, payload: bytes) -> type[Packet]:
        return FW1394


class Eth1394Response(Eth1394):
    """The 8 extra bytes come last on the wire; they are moved first to parse them."""

    name = "Eth1394 response"
    fields_desc = _flat_fields(flatten(EXTRA_BYTES))

    def pre_dissect(self, s: bytes) -> bytes:
        return s[-EXTRA_SIZE:] + s[:-EXTRA_SIZE]

    def post_dissect(self, s: bytes) -> bytes:
        # The cached raw bytes are in parsing order; drop them so building
        # goes through post_build and puts the extra bytes back at the end.
        self.raw_packet_cache = None
        return s

    def post_build(self, packet: bytes, payload: bytes) -> bytes:
        return payload + packet

    def guess_payload_class(self, payload: bytes) -> type[Packet]:
        return FW1394 if payload else Raw


class Answer(NamedTuple):
    """What came back for a packet :func:`sr1` sent: the ack and the response (None: silence)."""

    ack: FW1394Ack | None
    response: Packet | None


def sr1(
    packet: Packet | bytes,
    *,
    node: int | None = None,
    bus: str = DEFAULT_BUS,
    wait: float = 0.5,
    root: Path | None = None,
) -> Answer:
    """Put ``packet`` on bus ``bus`` as its host adapter; the ack and response it got.

    Like scapy's ``sr1`` for a virtual 1394 bus: the bytes of ``packet`` go out
    as they are (a CRC left at 0 stays wrong, which is the point of a
    malformed packet), to physical ID ``node`` or the one in its ``dst_id``.
    The response comes back as an :class:`FW1394` layer. Needs the adapter
    of ``fw1394 bus up``.
    """
    from fw1394.host.adapter_port import AdapterPort
    from fw1394.packets.ack import ack_byte
    from fw1394.packets.nodeid import phy_of

    raw = bytes(packet)
    if node is None:
        if len(raw) < DESTINATION_ID.end:
            raise ValueError(f"a {len(raw)}-byte packet names no destination: give node=")
        node = phy_of(DESTINATION_ID.of_bytes(raw))
    with AdapterPort(bus, root=root) as port:
        reply = port.send_packet(node, raw, wait)
    ack = None if reply.ack < 0 else FW1394Ack(bytes([ack_byte(reply.ack)]))
    return Answer(ack, FW1394(reply.data) if reply.data else None)


def sr(
    packets: Iterable[Packet | bytes],
    *,
    bus: str = DEFAULT_BUS,
    wait: float = 0.5,
    root: Path | None = None,
) -> list[tuple[Packet | bytes, Answer]]:
    """Each packet with what came back, as scapy's ``sr`` pairs them: one :func:`sr1` each."""
    return [(packet, sr1(packet, bus=bus, wait=wait, root=root)) for packet in packets]


conf.l2types.register(pseudo_header.LINKTYPE_FW1394, FW1394Capture)
bind_layers(UDP, Eth1394, dport=UDP_PORT)
bind_layers(UDP, Eth1394, sport=UDP_PORT)

__all__ = [
    "ASYNC_WITHOUT_CRC",
    "ASYNC_WITH_CRC",
    "FW1394",
    "PHY_LAYERS",
    "Answer",
    "Eth1394",
    "Eth1394Request",
    "Eth1394Response",
    "FW1394Ack",
    "FW1394Capture",
    "FW1394Phy",
    "sr",
    "sr1",
]
