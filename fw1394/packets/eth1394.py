"""Eth1394: the JHU FPGA1394 UDP framing around raw IEEE 1394 packets.

The JHU host library (Amp1394) and the FPGA1394 firmware tunnel plain 1394
asynchronous packets through UDP port 1394 on both ends:

* a request datagram is a 2-byte control word followed by the 1394 request
  packet (which therefore starts at payload offset 2, unaligned);
* a response datagram is the 1394 response packet followed by 8 "extra" bytes
  of FPGA status; a datagram of just those 8 bytes means "read dropped";
* writes are never answered.

This module is the only place the framing's layout is written down (the
``construct`` definitions below). It treats the 1394 packet as opaque bytes,
except in :func:`host_verdict`, which asks :mod:`fw1394.packets` for the few
header fields the host compares.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass
from typing import Any

from construct import (
    BitsInteger,
    BitStruct,
    Bytes,
    Flag,
    GreedyBytes,
    Int8ub,
    Int16ub,
    Struct,
    this,
)

from fw1394.errors import PacketError
from fw1394.packets.asynchronous import tcode_of
from fw1394.packets.enums import TCode
from fw1394.packets.fast import FIELD_NAMES, decode_header
from fw1394.packets.fields import FieldRangeError
from fw1394.packets.layouts import LAYOUTS
from fw1394.packets.nodeid import BROADCAST_PHY

# -- endpoints --------------------------------------------------------------------------

#: UDP port of both the host requests and the FPGA replies; hard-coded on both sides.
UDP_PORT = 1394
#: Multicast group used in Ethernet-only mode (firmware >= 9); the FPGA hard-codes it too.
MULTICAST_GROUP = "224.0.0.100"
#: Server address the host uses when none is given on its command line.
DEFAULT_SERVER_IP = "169.254.0.100"

# -- sizes (bytes) ----------------------------------------------------------------------

# The datagram sizes (control word, extra bytes, each request and response) are
# derived from the layouts below, after the framing structs.
#: The host caps any 1394 packet it sends or expects at this size.
MAX_FIREWIRE_PACKET_SIZE = 2048
#: IPv4 (20) + UDP (8) headers, which the host subtracts from the MTU.
IPV4_UDP_HEADER_SIZE = 28
#: MTU the host assumes until its first datagram arrives.
DEFAULT_MTU = 1500
#: The FPGA's receive buffer, in quadlets.
FPGA_RECEIVE_BUFFER_QUADLETS = 512
#: Block reads above this size overflow the real host's receive buffer on
#: loopback (its buffer is sized for MTU 1500, its checks use MTU 65536).
HOST_SAFE_READ_DATA_SIZE = 1440
#: The host waits this long (one select()) for each read response; no retry.
HOST_RECEIVE_TIMEOUT_S = 0.02
#: Destination node meaning "all nodes" (the 6-bit broadcast node number).
BROADCAST_NODE = BROADCAST_PHY


def max_read_data_size(mtu: int = DEFAULT_MTU) -> int:
    """Largest block-read data size the host asks for at this MTU (1440 at 1500)."""
    return min(MAX_FIREWIRE_PACKET_SIZE, mtu - IPV4_UDP_HEADER_SIZE - EXTRA_SIZE) - (
        BLOCK_PACKET_OVERHEAD
    )


def max_write_data_size(mtu: int = DEFAULT_MTU) -> int:
    """Largest block-write data size the host allows at this MTU (1446 at 1500).

    The host also needs a multiple of 4, so 1444 bytes is the usable maximum
    at MTU 1500 (see :func:`usable_write_data_size`).
    """
    return min(MAX_FIREWIRE_PACKET_SIZE, mtu - IPV4_UDP_HEADER_SIZE - CONTROL_WORD_SIZE) - (
        BLOCK_PACKET_OVERHEAD
    )


def usable_write_data_size(mtu: int = DEFAULT_MTU) -> int:
    """:func:`max_write_data_size` rounded down to whole quadlets."""
    return max_write_data_size(mtu) & ~3


def expected_response_size(data_length: int | None = None) -> int:
    """Datagram size the host waits for: 28 for a quadlet read, 32 + N for a block read."""
    if data_length is None:
        return QUADLET_RESPONSE_SIZE
    return BLOCK_RESPONSE_BASE_SIZE + data_length


# -- host-side node flags (not on the wire) -------------------------------------------


class HostNodeFlag(enum.IntFlag):
    """Flags the host library ORs into the node argument of its node-level calls.

    They never travel as such: ``NO_FORWARD`` becomes the control word's
    no-forward bit, ``ETH_BROADCAST`` picks the broadcast/multicast address.
    """

    NO_FORWARD = 0x40
    ETH_BROADCAST = 0x80


# -- wire layouts -----------------------------------------------------------------------

#: Byte 0 of a request: FW_CTRL flags. Only bit 0 is defined; the host sends the
#: other bits as 0 and the FPGA ignores them, but they are kept to rebuild any input.
CONTROL_FLAGS = BitStruct(
    "reserved" / BitsInteger(7),
    "no_forward" / Flag,
)
#: The 2-byte control word that precedes every request packet.
CONTROL_WORD = Struct(
    "flags" / CONTROL_FLAGS,
    "bus_generation" / Int8ub,  # the host's idea of the FireWire bus generation
)
#: Byte 0 of the extra bytes: FPGA status flags.
EXTRA_FLAGS = BitStruct(
    "reserved" / Flag,  # always 0 from the FPGA
    "switch_source_port" / BitsInteger(2),  # Ethernet switch port (FPGA V3; 0 on V2)
    "no_forward_echo" / Flag,  # the request's no-forward flag, echoed
    "summary_error" / Flag,  # sticky frame/IPv4/UDP-port/destination error
    "internal_error" / Flag,  # send/receive state error or low-level error
    "packet_dropped" / Flag,  # bus reset or generation mismatch
    "bus_reset" / Flag,  # FireWire bus reset in progress
)
#: The 8 bytes the FPGA appends to every response.
EXTRA_BYTES = Struct(
    "flags" / EXTRA_FLAGS,
    "fpga_bus_generation" / Int8ub,  # increments at the end of each bus reset
    "state_glitch_count" / Int8ub,  # only counts in debug builds, else 0
    "packet_error_count" / Int8ub,  # frame/IPv4/UDP errors
    "receive_ticks" / Int16ub,  # start of frame to end of receive, 49.152 MHz, saturating
    "total_ticks" / Int16ub,  # start of frame to the moment this word is sent
)
#: A request datagram: control word, then the 1394 request packet.
REQUEST_DATAGRAM = Struct(
    "control" / CONTROL_WORD,
    "packet" / GreedyBytes,
)
#: A response datagram; parse and build with ``packet_size=`` in the context.
RESPONSE_DATAGRAM = Struct(
    "packet" / Bytes(this._params.packet_size),
    "extra" / EXTRA_BYTES,
)


# -- sizes (bytes), from the framing structs and the 1394 packet layouts -----------------


def _wire_size(tcode: TCode) -> int:
    """Bytes of a 1394 packet with its CRCs and no data: header, header CRC, data CRC."""
    layout = LAYOUTS[tcode]
    return 4 * layout.sealed_header.count + (4 if layout.has_data else 0)


CONTROL_WORD_SIZE: int = CONTROL_WORD.sizeof()
EXTRA_SIZE: int = EXTRA_BYTES.sizeof()
#: Request datagrams: control word + 1394 packet (16 / 20 / 20 / 24 + N bytes).
QREAD_REQUEST_SIZE = CONTROL_WORD_SIZE + _wire_size(TCode.read_quadlet_request)
QWRITE_REQUEST_SIZE = CONTROL_WORD_SIZE + _wire_size(TCode.write_quadlet_request)
BREAD_REQUEST_SIZE = CONTROL_WORD_SIZE + _wire_size(TCode.read_block_request)
BWRITE_REQUEST_BASE_SIZE = CONTROL_WORD_SIZE + _wire_size(TCode.write_block_request)
#: Response datagrams: 1394 packet + extra bytes. Block responses add N data bytes.
QUADLET_RESPONSE_SIZE = _wire_size(TCode.read_quadlet_response) + EXTRA_SIZE
BLOCK_RESPONSE_BASE_SIZE = _wire_size(TCode.read_block_response) + EXTRA_SIZE
#: The "read dropped" notice: extra bytes and nothing else.
EXTRA_ONLY_RESPONSE_SIZE = EXTRA_SIZE
#: Bytes of a block packet besides its data (header, both CRCs), which the host
#: subtracts from its data budget.
BLOCK_PACKET_OVERHEAD = _wire_size(TCode.read_block_response)


# -- errors -----------------------------------------------------------------------------


class Eth1394Error(PacketError):
    """A datagram or a field of one does not fit the framing."""


class DatagramTooShortError(Eth1394Error):
    """Fewer bytes than the framing itself needs."""


class ResponseSizeError(Eth1394Error):
    """A response shorter than the size the host waits for."""


def _check_range(field: str, value: int, bits: int) -> None:
    if not 0 <= value < 1 << bits:
        raise FieldRangeError(field, f"{value} does not fit in {bits} bits")


# -- values -----------------------------------------------------------------------------


@dataclass(frozen=True)
class ControlWord:
    """The 2-byte control word of a request."""

    no_forward: bool = False
    bus_generation: int = 0
    #: Bits 7..1 of byte 0: undefined, 0 from the host, ignored by the FPGA.
    reserved_flags: int = 0

    def __post_init__(self) -> None:
        _check_range("bus_generation", self.bus_generation, 8)
        _check_range("reserved_flags", self.reserved_flags, 7)


@dataclass(frozen=True)
class ExtraBytes:
    """The 8 status bytes the FPGA appends to each response (byte 0 flags first)."""

    bus_reset: bool = False
    packet_dropped: bool = False
    internal_error: bool = False
    summary_error: bool = False
    no_forward_echo: bool = False
    switch_source_port: int = 0
    reserved: bool = False
    fpga_bus_generation: int = 0
    state_glitch_count: int = 0
    packet_error_count: int = 0
    receive_ticks: int = 0
    total_ticks: int = 0

    def __post_init__(self) -> None:
        _check_range("switch_source_port", self.switch_source_port, 2)
        for name in ("fpga_bus_generation", "state_glitch_count", "packet_error_count"):
            _check_range(name, getattr(self, name), 8)
        _check_range("receive_ticks", self.receive_ticks, 16)
        _check_range("total_ticks", self.total_ticks, 16)

    @property
    def receive_seconds(self) -> float:
        """:attr:`receive_ticks` as the host reports it (FPGA_RecvTime)."""
        return self.receive_ticks / 49.152e6

    @property
    def total_seconds(self) -> float:
        """:attr:`total_ticks` as the host reports it (FPGA_TotalTime)."""
        return self.total_ticks / 49.152e6


@dataclass(frozen=True)
class Eth1394Request:
    """A request datagram split into its control word and its 1394 packet."""

    control: ControlWord
    packet: bytes


@dataclass(frozen=True)
class Eth1394Response:
    """A response datagram split into its 1394 packet and its extra bytes."""

    packet: bytes
    extra: ExtraBytes

    @property
    def is_extra_only(self) -> bool:
        """True for the 8-byte "read dropped" notice (no 1394 packet)."""
        return not self.packet


# -- conversions between the dataclasses and the construct containers ---------------------


def _control_from_container(parsed: Any) -> ControlWord:
    return ControlWord(
        no_forward=bool(parsed.flags.no_forward),
        bus_generation=int(parsed.bus_generation),
        reserved_flags=int(parsed.flags.reserved),
    )


def _control_to_dict(control: ControlWord) -> dict[str, Any]:
    return {
        "flags": {"reserved": control.reserved_flags, "no_forward": control.no_forward},
        "bus_generation": control.bus_generation,
    }


_EXTRA_FLAG_NAMES = (
    "reserved",
    "switch_source_port",
    "no_forward_echo",
    "summary_error",
    "internal_error",
    "packet_dropped",
    "bus_reset",
)
_EXTRA_BYTE_NAMES = (
    "fpga_bus_generation",
    "state_glitch_count",
    "packet_error_count",
    "receive_ticks",
    "total_ticks",
)


def _extra_from_container(parsed: Any) -> ExtraBytes:
    values: dict[str, Any] = {name: parsed.flags[name] for name in _EXTRA_FLAG_NAMES}
    values.update((name, int(parsed[name])) for name in _EXTRA_BYTE_NAMES)
    return ExtraBytes(**values)


def _extra_to_dict(extra: ExtraBytes) -> dict[str, Any]:
    values: dict[str, Any] = {name: getattr(extra, name) for name in _EXTRA_BYTE_NAMES}
    values["flags"] = {name: getattr(extra, name) for name in _EXTRA_FLAG_NAMES}
    return values


# -- framing ----------------------------------------------------------------------------


def parse_request(payload: bytes) -> Eth1394Request:
    """Split a request datagram's UDP payload into control word and 1394 packet.

    The packet is returned as is, whatever its length: the FPGA itself copes
    with short or long packets in its own ways (see the 1394 decoder).
    """
    if len(payload) < CONTROL_WORD_SIZE:
        raise DatagramTooShortError(
            "control_word", f"needs {CONTROL_WORD_SIZE} bytes, datagram has {len(payload)}"
        )
    parsed = REQUEST_DATAGRAM.parse(payload)
    return Eth1394Request(_control_from_container(parsed.control), bytes(parsed.packet))


def build_request(request: Eth1394Request) -> bytes:
    """UDP payload of a request: control word, then the 1394 packet."""
    built: bytes = REQUEST_DATAGRAM.build(
        {"control": _control_to_dict(request.control), "packet": request.packet}
    )
    return built


def parse_response(payload: bytes, expected_packet_size: int | None = None) -> Eth1394Response:
    """Split a response datagram into its 1394 packet and its extra bytes.

    Without ``expected_packet_size`` the last 8 bytes are the extra bytes.
    With it, the payload is read the way the host reads it: an 8-byte payload
    is the extra-only "read dropped" notice, a shorter-than-expected payload is
    refused, and a longer one is cut to the expected size first (the host's
    ``recv`` buffer is exactly that big), so its extra bytes are taken from
    wherever the cut puts them.
    """
    if len(payload) < EXTRA_SIZE:
        raise DatagramTooShortError(
            "extra", f"needs {EXTRA_SIZE} bytes, datagram has {len(payload)}"
        )
    if expected_packet_size is not None and len(payload) != EXTRA_SIZE:
        if expected_packet_size < 0:
            raise Eth1394Error("expected_packet_size", f"{expected_packet_size} is negative")
        wanted = expected_packet_size + EXTRA_SIZE
        if len(payload) < wanted:
            raise ResponseSizeError("datagram", f"{len(payload)} bytes, host waits for {wanted}")
        payload = payload[:wanted]
    parsed = RESPONSE_DATAGRAM.parse(payload, packet_size=len(payload) - EXTRA_SIZE)
    return Eth1394Response(bytes(parsed.packet), _extra_from_container(parsed.extra))


def build_response(response: Eth1394Response) -> bytes:
    """UDP payload of a response: the 1394 packet, then the extra bytes."""
    built: bytes = RESPONSE_DATAGRAM.build(
        {"packet": response.packet, "extra": _extra_to_dict(response.extra)},
        packet_size=len(response.packet),
    )
    return built


# -- the host's view of a response ------------------------------------------------------


@dataclass(frozen=True)
class HostReadRequest:
    """What the host remembers of the read it just sent, to judge the answer.

    ``node`` is the 6-bit destination node (``BROADCAST_NODE`` for the
    broadcast reads, whose answer may come from any node), ``tl`` the label it
    used (for the broadcast query's answer: the label of the 0x1800 write),
    ``data_length`` the block size in bytes, or None for a quadlet read.
    """

    node: int
    tl: int
    data_length: int | None = None

    def __post_init__(self) -> None:
        _check_range("node", self.node, 6)
        _check_range("tl", self.tl, 6)
        if self.data_length is not None:
            _check_range("data_length", self.data_length, 16)

    @property
    def expected_tcode(self) -> TCode:
        if self.data_length is None:
            return TCode.read_quadlet_response
        return TCode.read_block_response

    @property
    def expected_size(self) -> int:
        """Size of the datagram the host's ``recv`` buffer holds."""
        return expected_response_size(self.data_length)


class HostVerdict(enum.Enum):
    """How the real host treats one received datagram, checks in the host's order."""

    ACCEPTED = "accepted"
    EXTRA_ONLY = "only extra data"
    TOO_SHORT = "shorter than expected"
    UNEXPECTED_TCODE = "Unexpected tcode"
    INCONSISTENT_SOURCE_NODE = "Inconsistent source node"
    INCONSISTENT_TL = "Inconsistent Firewire TL"
    INCONSISTENT_LENGTH = "Inconsistent length"


def host_verdict(request: HostReadRequest, datagram: bytes) -> HostVerdict:
    """Judge a response datagram exactly as the host does for a read.

    Nothing else is looked at: not the CRCs, rcode, destination ID, rt, pri,
    quadlet 2 or extended tcode, and a longer datagram is cut, not refused.
    """
    if len(datagram) == EXTRA_SIZE:
        return HostVerdict.EXTRA_ONLY
    if len(datagram) < request.expected_size:
        return HostVerdict.TOO_SHORT
    packet = datagram[: request.expected_size - EXTRA_SIZE]
    tcode = tcode_of(packet)
    if tcode != request.expected_tcode:
        return HostVerdict.UNEXPECTED_TCODE
    header = dict(zip(FIELD_NAMES[tcode], decode_header(packet), strict=True))
    source_node = header["source_id"] & BROADCAST_NODE  # the host ignores the bus number
    if request.node != BROADCAST_NODE and source_node != request.node:
        return HostVerdict.INCONSISTENT_SOURCE_NODE
    if header["tlabel"] != request.tl:
        return HostVerdict.INCONSISTENT_TL
    if request.data_length is not None and header["data_length"] != request.data_length:
        return HostVerdict.INCONSISTENT_LENGTH
    return HostVerdict.ACCEPTED


def host_accepts(request: HostReadRequest, datagram: bytes) -> bool:
    """True if the host would return this datagram's data for ``request``."""
    return host_verdict(request, datagram) is HostVerdict.ACCEPTED


def host_sees_bus_reset(host_generation: int, extra: ExtraBytes) -> bool:
    """True if the host would report a FireWire bus reset on these extra bytes.

    The host compares the FPGA's generation with its own on every response,
    unless the response echoes the no-forward flag.
    """
    return extra.fpga_bus_generation != host_generation and not extra.no_forward_echo
