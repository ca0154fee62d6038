"""JHU Eth1394 traffic in ordinary captures: link layer, IP, UDP 1394, then 1394 packets.

Both ends use UDP port 1394, so ports cannot tell a request from a response.
The payload can: a request is a 2-byte control word followed by a request
packet, a response is a response packet followed by 8 extra bytes, and the
tcode sits in a different byte in each case (see :func:`classify`).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from fw1394.capture.formats.pcap_writer import (
    LINKTYPE_ETHERNET,
    LINKTYPE_IPV4,
    LINKTYPE_IPV6,
    LINKTYPE_LINUX_SLL,
    LINKTYPE_LINUX_SLL2,
    LINKTYPE_LOOP,
    LINKTYPE_NULL,
    LINKTYPE_RAW,
)
from fw1394.capture.formats.read_issues import Issue
from fw1394.capture.formats.record import SPEED_UNKNOWN, BusRecord, Direction, RecordType
from fw1394.packets import LAYOUTS
from fw1394.packets.accessors import DESTINATION_ID, SOURCE_ID, TCODE, layout_reader
from fw1394.packets.eth1394 import (
    CONTROL_WORD_SIZE,
    EXTRA_SIZE,
    UDP_PORT,
    Eth1394Error,
    parse_request,
    parse_response,
)
from fw1394.packets.nodeid import phy_of
from fw1394.packets.tcodes import REQUEST_TCODES, RESPONSE_TCODES

_ETHERTYPE_IPV4, _ETHERTYPE_IPV6, _ETHERTYPE_VLAN = 0x0800, 0x86DD, 0x8100
_UDP = 17


def wire_size(packet: bytes) -> int | None:
    """Bytes the 1394 packet at the start of ``packet`` should have, with CRCs (None: unknown)."""
    if len(packet) < TCODE.end:
        return None
    layout = LAYOUTS.get(TCODE.of_bytes(packet))  # type: ignore[call-overload]
    if layout is None:
        return None
    size = 4 * layout.sealed_header.count
    if not layout.has_data:
        return int(size)
    if len(packet) < size:
        return None
    length = layout_reader(layout.tcode, "data_length").of_bytes(packet)
    return int(size + ((length + 3) & ~3) + 4)


def classify(payload: bytes) -> str | None:
    """``request``, ``response``, ``extra_only`` or None for an Eth1394 UDP payload."""
    if len(payload) == EXTRA_SIZE:
        return "extra_only"
    request, response = payload[CONTROL_WORD_SIZE:], payload[:-EXTRA_SIZE]
    as_request = len(request) >= TCODE.end and TCODE.of_bytes(request) in REQUEST_TCODES
    as_response = (
        len(payload) >= EXTRA_SIZE + TCODE.end and TCODE.of_bytes(response) in RESPONSE_TCODES
    )
    if as_request and as_response:
        # Both readings start plausibly: the one whose size adds up wins.
        if wire_size(request) == len(request):
            return "request"
        if wire_size(response) == len(response):
            return "response"
    if as_request:
        return "request"
    if as_response:
        return "response"
    return None


@dataclass(frozen=True)
class Datagram:
    payload: bytes
    source: str
    destination: str


def udp_payload(
    linktype: int, frame: bytes, ports: tuple[int, ...] = (UDP_PORT,)
) -> Datagram | str | None:
    """The Eth1394 datagram in a captured frame; None for other traffic; a str: a problem."""
    network, offset = _network_layer(linktype, frame)
    if network is None:
        return None if offset == 0 else f"unsupported link type {linktype}"
    if network == _ETHERTYPE_IPV4:
        if len(frame) < offset + 20:
            return None
        version_ihl, _, total, _, fragment, _, protocol = struct.unpack_from(
            ">BBHHHBB", frame, offset
        )
        header = (version_ihl & 0xF) * 4
        if protocol != _UDP or header < 20:
            return None
        if fragment & 0x1FFF or fragment & 0x2000:
            return "fragmented IPv4 datagram (not reassembled)"
        source = ".".join(str(b) for b in frame[offset + 12 : offset + 16])
        destination = ".".join(str(b) for b in frame[offset + 16 : offset + 20])
        end = min(len(frame), offset + total) if total else len(frame)
        udp = offset + header
    elif network == _ETHERTYPE_IPV6:
        if len(frame) < offset + 40 or frame[offset + 6] != _UDP:
            return None
        source = frame[offset + 8 : offset + 24].hex()
        destination = frame[offset + 24 : offset + 40].hex()
        end = len(frame)
        udp = offset + 40
    else:
        return None
    if end < udp + 8:
        return None
    source_port, destination_port, length = struct.unpack_from(">HHH", frame, udp)
    if source_port not in ports and destination_port not in ports:
        return None
    end = min(end, udp + length) if length >= 8 else end
    return Datagram(bytes(frame[udp + 8 : end]), source, destination)


def _network_layer(linktype: int, frame: bytes) -> tuple[int | None, int]:
    """(ethertype, offset of the network header); (None, 0) for other traffic."""
    if linktype == LINKTYPE_ETHERNET:
        if len(frame) < 14:
            return None, 0
        ethertype, offset = struct.unpack_from(">H", frame, 12)[0], 14
        while ethertype == _ETHERTYPE_VLAN and len(frame) >= offset + 4:
            ethertype, offset = struct.unpack_from(">H", frame, offset + 2)[0], offset + 4
        return ethertype, offset
    if linktype == LINKTYPE_LINUX_SLL:
        return (struct.unpack_from(">H", frame, 14)[0], 16) if len(frame) >= 16 else (None, 0)
    if linktype == LINKTYPE_LINUX_SLL2:
        return (struct.unpack_from(">H", frame, 0)[0], 20) if len(frame) >= 20 else (None, 0)
    if linktype in (LINKTYPE_RAW, LINKTYPE_IPV4, LINKTYPE_IPV6):
        if not frame:
            return None, 0
        return (_ETHERTYPE_IPV4 if frame[0] >> 4 == 4 else _ETHERTYPE_IPV6), 0
    if linktype in (LINKTYPE_NULL, LINKTYPE_LOOP):
        # A 4-byte address family in the capturing host's byte order; the IP
        # version nibble that follows says the same thing more portably.
        if len(frame) < 5:
            return None, 0
        return (_ETHERTYPE_IPV4 if frame[4] >> 4 == 4 else _ETHERTYPE_IPV6), 4
    return None, 1


class Eth1394Decoder:
    """Turns Eth1394 datagrams into bus records, following the FPGA's bus generation."""

    def __init__(self) -> None:
        self.generation = 0
        self._seen_generation = False

    def records(self, datagram: Datagram, timestamp_ns: int) -> list[BusRecord] | Issue | None:
        """Records for one datagram (a bus reset first when the generation moved)."""
        kind = classify(datagram.payload)
        try:
            if kind == "request":
                return [self._request(datagram.payload, timestamp_ns)]
            if kind == "response":
                return self._response(datagram.payload, timestamp_ns)
        except Eth1394Error as error:
            return Issue(0, f"Eth1394: {error}")
        if kind == "extra_only":
            return Issue(0, "Eth1394 read dropped by the FPGA (extra bytes only)")
        return Issue(0, f"UDP 1394 datagram of {len(datagram.payload)} bytes is not Eth1394")

    def _request(self, payload: bytes, timestamp_ns: int) -> BusRecord:
        request = parse_request(payload)
        packet = request.packet
        sender = phy_of(SOURCE_ID.of_bytes(packet)) if len(packet) >= SOURCE_ID.end else None
        return BusRecord(
            timestamp_ns,
            RecordType.async_packet,
            packet,
            generation=request.control.bus_generation,  # the host's idea of it
            sender=sender,
            speed=SPEED_UNKNOWN,
            direction=Direction.outbound,
            observer=sender,
        )

    def _response(self, payload: bytes, timestamp_ns: int) -> list[BusRecord]:
        response = parse_response(payload)
        packet = response.packet
        records = []
        fpga_generation = response.extra.fpga_bus_generation
        if self._seen_generation and fpga_generation != self.generation:
            records.append(BusRecord(timestamp_ns, RecordType.bus_reset, b"", fpga_generation))
        self.generation, self._seen_generation = fpga_generation, True
        size = wire_size(packet) or len(packet)
        # The FPGA's Ethernet path leaves both CRC quadlets zero: not an error.
        placeholder = len(packet) >= 4 and packet[-4:] == bytes(4) and size == len(packet)
        records.append(
            BusRecord(
                timestamp_ns,
                RecordType.async_packet,
                packet,
                generation=fpga_generation,
                sender=phy_of(SOURCE_ID.of_bytes(packet)) if len(packet) >= SOURCE_ID.end else None,
                speed=SPEED_UNKNOWN,
                direction=Direction.inbound,
                observer=(
                    phy_of(DESTINATION_ID.of_bytes(packet))
                    if len(packet) >= DESTINATION_ID.end
                    else None
                ),
                crc_placeholder=placeholder,
            )
        )
        return records
