"""Eth1394 UDP framing: captured datagrams, the host's response rules, round trips.

Every hex string below is a datagram the real JHU host produced (or, for the
responses, one it accepted), as recorded in the reference notes.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets.eth1394 import (
    BLOCK_RESPONSE_BASE_SIZE,
    BREAD_REQUEST_SIZE,
    BROADCAST_NODE,
    BWRITE_REQUEST_BASE_SIZE,
    CONTROL_WORD_SIZE,
    EXTRA_SIZE,
    MULTICAST_GROUP,
    QREAD_REQUEST_SIZE,
    QUADLET_RESPONSE_SIZE,
    QWRITE_REQUEST_SIZE,
    UDP_PORT,
    ControlWord,
    DatagramTooShortError,
    Eth1394Error,
    Eth1394Request,
    Eth1394Response,
    ExtraBytes,
    HostNodeFlag,
    HostReadRequest,
    HostVerdict,
    ResponseSizeError,
    build_request,
    build_response,
    expected_response_size,
    host_accepts,
    host_sees_bus_reset,
    host_verdict,
    max_read_data_size,
    max_write_data_size,
    parse_request,
    parse_response,
    usable_write_data_size,
)
from fw1394.packets.fields import FieldRangeError


def unhex(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", ""))


QWRITE, BWRITE, QREAD, BREAD = 0, 1, 4, 5

# (what, payload, no-forward flag, host bus generation, tcode, block data length)
CAPTURED_REQUESTS = [
    (
        "broadcast qwrite IP_ADDR",
        "0100 ffff0400 ffd00000 0000000b 0100007f 11c036d8",
        True,
        0,
        QWRITE,
        None,
    ),
    (
        "broadcast qread HW_VERSION",
        "0100 ffff0840 ffd00000 00000004 58ffb182",
        True,
        0,
        QREAD,
        None,
    ),
    ("unicast qread HW_VERSION", "0105 ffc01c40 ffd00000 00000004 a9927b79", True, 5, QREAD, None),
    ("qread status", "0105 ffc02840 ffd00000 00000000 c0518b0f", True, 5, QREAD, None),
    (
        "bread RT block",
        "0105 ffc09c50 ffd00000 00000000 00800000 fc9a49db",
        True,
        5,
        BREAD,
        None,
    ),
    (
        "bwrite Rev 8 RT write",
        "0105 ffc0a010 ffd00000 00000000 00180000 48855894 00000006 80008000 80008000"
        " 80008000 80008000 00000000 c4d5d450",
        True,
        5,
        BWRITE,
        24,
    ),
    (
        "bwrite 0x2000",
        "0105 ffc06c10 ffd00000 00002000 000c0000 cca946ca 00000011 00000022 00000033 54289f99",
        True,
        5,
        BWRITE,
        12,
    ),
    (
        "multicast qwrite close relays",
        "0105 ffff6c00 ffd00000 00000000 00030000 d62f5854",
        True,
        5,
        QWRITE,
        None,
    ),
    (
        "multicast broadcast query",
        "0105 ffff9c00 ffd00000 00001800 00010001 d1739470",
        True,
        5,
        QWRITE,
        None,
    ),
    (
        "bridge-mode unicast qread",
        "0007 ffc13040 ffd00000 00000004 127ae411",
        False,
        7,
        QREAD,
        None,
    ),
    (
        "broadcast RT write (section 2.10)",
        "0105 ffffa410 ffd00000 00000000 00180000 9c5a0a97 00000006 00000000 00000000"
        " 00000000 00000000 00000000 90451703",
        True,
        5,
        BWRITE,
        24,
    ),
    (
        "hub fallback bread 0x1000 (section 2.10)",
        "0105 ffc0a050 ffd00000 00001000 00880000 ddb52355",
        True,
        5,
        BREAD,
        None,
    ),
]

#: 1394 packet sizes of section 1.2 and datagram sizes of section 2.3.
PACKET_SIZE = {QREAD: 16, QWRITE: 20, BREAD: 20, BWRITE: 24}
DATAGRAM_SIZE = {
    QREAD: QREAD_REQUEST_SIZE,
    QWRITE: QWRITE_REQUEST_SIZE,
    BREAD: BREAD_REQUEST_SIZE,
    BWRITE: BWRITE_REQUEST_BASE_SIZE,
}

#: The response the real host accepted (zero CRC, Ethernet-only, generation 5).
ACCEPTED_QRESP = "ffd01c60 ffc00000 00000000 514c4131 00000000"
ACCEPTED_EXTRA = "10 05 00 00 00 64 00 c8"


def quadlet_response(tl: int, source_node: int, rcode: int = 0, tcode: int = 6) -> bytes:
    """A QRESP to 0xFFD0 carrying 'QLA1', header fields placed per section 1.1."""
    q0 = 0xFFD0 << 16 | tl << 10 | tcode << 4
    q1 = (0xFFC0 | source_node) << 16 | rcode << 12
    return b"".join(q.to_bytes(4, "big") for q in (q0, q1, 0, 0x514C4131, 0))


def block_response(tl: int, source_node: int, data: bytes, length: int | None = None) -> bytes:
    q0 = 0xFFD0 << 16 | tl << 10 | 7 << 4
    q1 = (0xFFC0 | source_node) << 16
    q3 = (len(data) if length is None else length) << 16
    header = b"".join(q.to_bytes(4, "big") for q in (q0, q1, 0, q3, 0))
    return header + data + bytes(4)


@pytest.mark.parametrize(
    ("what", "payload", "no_forward", "generation", "tcode", "data_length"),
    CAPTURED_REQUESTS,
    ids=[row[0] for row in CAPTURED_REQUESTS],
)
def test_captured_requests_parse(
    what: str,
    payload: str,
    no_forward: bool,
    generation: int,
    tcode: int,
    data_length: int | None,
) -> None:
    raw = unhex(payload)
    request = parse_request(raw)
    assert request.control.no_forward is no_forward
    assert request.control.bus_generation == generation
    assert request.control.reserved_flags == 0
    # Section 1.1: tcode is quadlet 0 bits 7..4 of the packet, after the control word.
    assert request.packet[3] >> 4 == tcode
    extra_data = data_length or 0
    assert len(request.packet) == PACKET_SIZE[tcode] + extra_data
    assert len(raw) == DATAGRAM_SIZE[tcode] + extra_data
    assert request.packet == raw[CONTROL_WORD_SIZE:]
    assert build_request(request) == raw


def test_captured_response_extra_bytes() -> None:
    raw = unhex(ACCEPTED_QRESP + ACCEPTED_EXTRA)
    assert len(raw) == QUADLET_RESPONSE_SIZE
    response = parse_response(raw, expected_packet_size=20)
    assert response.packet == unhex(ACCEPTED_QRESP)
    assert response.extra == ExtraBytes(
        no_forward_echo=True,  # byte 0 = 0x10: bit 4
        fpga_bus_generation=5,
        state_glitch_count=0,
        packet_error_count=0,
        receive_ticks=0x64,
        total_ticks=0xC8,
    )
    assert response.extra.receive_seconds == pytest.approx(100 / 49.152e6)
    assert not response.is_extra_only
    assert parse_response(raw) == response
    assert build_response(response) == raw


def test_captured_response_is_accepted_by_the_host() -> None:
    raw = unhex(ACCEPTED_QRESP + ACCEPTED_EXTRA)
    assert host_accepts(HostReadRequest(node=0, tl=7), raw)
    # The same response with the real CRC is equally fine: CRCs are never checked.
    with_crc = unhex("ffd01c60 ffc00000 00000000 514c4131 2428f807" + ACCEPTED_EXTRA)
    assert host_accepts(HostReadRequest(node=0, tl=7), with_crc)


def test_host_cuts_long_datagrams_and_refuses_short_ones() -> None:
    raw = unhex(ACCEPTED_QRESP + ACCEPTED_EXTRA)
    request = HostReadRequest(node=0, tl=7)
    assert host_verdict(request, raw + bytes(4)) is HostVerdict.ACCEPTED  # 32 bytes
    assert host_verdict(request, raw[:27]) is HostVerdict.TOO_SHORT
    assert host_verdict(request, raw[-EXTRA_SIZE:]) is HostVerdict.EXTRA_ONLY
    # parse_response mimics the cut: the extra bytes come from where the host reads them.
    cut = parse_response(raw + b"\xff" * 4, expected_packet_size=20)
    assert cut.extra.fpga_bus_generation == 5
    with pytest.raises(ResponseSizeError, match="datagram"):
        parse_response(raw[:27], expected_packet_size=20)


def test_host_checks_tcode_source_node_tl_and_length_only() -> None:
    extra = unhex(ACCEPTED_EXTRA)
    request = HostReadRequest(node=2, tl=9)
    assert host_verdict(request, quadlet_response(9, 2) + extra) is HostVerdict.ACCEPTED
    # rcode 7 (address error) is not looked at.
    assert host_verdict(request, quadlet_response(9, 2, rcode=7) + extra) is HostVerdict.ACCEPTED
    assert (
        host_verdict(request, quadlet_response(9, 3) + extra)
        is HostVerdict.INCONSISTENT_SOURCE_NODE
    )
    assert host_verdict(request, quadlet_response(8, 2) + extra) is HostVerdict.INCONSISTENT_TL
    assert (
        host_verdict(request, quadlet_response(9, 2, tcode=2) + extra)
        is HostVerdict.UNEXPECTED_TCODE
    )
    # A broadcast read takes its answer from any node.
    broadcast = HostReadRequest(node=BROADCAST_NODE, tl=9)
    assert host_accepts(broadcast, quadlet_response(9, 5) + extra)


def test_host_checks_block_length() -> None:
    extra = unhex(ACCEPTED_EXTRA)
    data = bytes(range(8))
    request = HostReadRequest(node=0, tl=39, data_length=8)
    good = block_response(39, 0, data) + extra
    assert len(good) == BLOCK_RESPONSE_BASE_SIZE + 8 == request.expected_size
    assert host_verdict(request, good) is HostVerdict.ACCEPTED
    wrong_length = block_response(39, 0, data, length=12) + extra
    assert host_verdict(request, wrong_length) is HostVerdict.INCONSISTENT_LENGTH
    quadlet_answer = quadlet_response(39, 0) + extra + bytes(12)
    assert host_verdict(request, quadlet_answer) is HostVerdict.UNEXPECTED_TCODE


def test_extra_only_notice() -> None:
    dropped = bytes([0x02, 0x07, 0, 0, 0, 0, 0, 0])
    response = parse_response(dropped, expected_packet_size=20)
    assert response.is_extra_only
    assert response.extra.packet_dropped
    assert response.extra.fpga_bus_generation == 7
    assert build_response(response) == dropped


def test_extra_flag_bits_positions() -> None:
    # Byte 0: bit 0 bus reset, 1 dropped, 2 internal, 3 summary, 4 echo, 6..5 port, 7 zero.
    cases = {
        0x01: ExtraBytes(bus_reset=True),
        0x02: ExtraBytes(packet_dropped=True),
        0x04: ExtraBytes(internal_error=True),
        0x08: ExtraBytes(summary_error=True),
        0x10: ExtraBytes(no_forward_echo=True),
        0x40: ExtraBytes(switch_source_port=2),
        0x80: ExtraBytes(reserved=True),
    }
    for byte0, extra in cases.items():
        assert parse_response(bytes([byte0]) + bytes(7)).extra == extra


def test_bus_reset_report() -> None:
    assert host_sees_bus_reset(4, ExtraBytes(fpga_bus_generation=5))
    assert not host_sees_bus_reset(4, ExtraBytes(fpga_bus_generation=5, no_forward_echo=True))
    assert not host_sees_bus_reset(5, ExtraBytes(fpga_bus_generation=5))


def test_errors_name_the_field() -> None:
    with pytest.raises(DatagramTooShortError, match="control_word"):
        parse_request(b"\x01")
    with pytest.raises(DatagramTooShortError, match="extra"):
        parse_response(bytes(7))
    with pytest.raises(FieldRangeError, match="bus_generation"):
        ControlWord(bus_generation=256)
    with pytest.raises(FieldRangeError, match="total_ticks"):
        ExtraBytes(total_ticks=0x10000)
    with pytest.raises(FieldRangeError, match="tl"):
        HostReadRequest(node=0, tl=64)
    assert issubclass(Eth1394Error, ValueError)


def test_constants_and_sizes() -> None:
    assert UDP_PORT == 1394
    assert MULTICAST_GROUP == "224.0.0.100"
    assert (CONTROL_WORD_SIZE, EXTRA_SIZE) == (2, 8)
    assert expected_response_size() == 28
    assert expected_response_size(128) == 32 + 128
    assert max_read_data_size(1500) == 1440
    assert max_read_data_size(65536) == 2024
    assert max_write_data_size(1500) == 1446
    assert usable_write_data_size(1500) == 1444
    assert HostNodeFlag.NO_FORWARD | HostNodeFlag.ETH_BROADCAST == 0xC0


# -- round trips ------------------------------------------------------------------------


@given(st.binary(min_size=CONTROL_WORD_SIZE, max_size=64))
def test_request_round_trip(payload: bytes) -> None:
    assert build_request(parse_request(payload)) == payload


@given(st.binary(min_size=EXTRA_SIZE, max_size=64))
def test_response_round_trip(payload: bytes) -> None:
    assert build_response(parse_response(payload)) == payload


controls = st.builds(
    ControlWord,
    no_forward=st.booleans(),
    bus_generation=st.integers(0, 255),
    reserved_flags=st.integers(0, 127),
)
extras = st.builds(
    ExtraBytes,
    bus_reset=st.booleans(),
    packet_dropped=st.booleans(),
    internal_error=st.booleans(),
    summary_error=st.booleans(),
    no_forward_echo=st.booleans(),
    switch_source_port=st.integers(0, 3),
    reserved=st.booleans(),
    fpga_bus_generation=st.integers(0, 255),
    state_glitch_count=st.integers(0, 255),
    packet_error_count=st.integers(0, 255),
    receive_ticks=st.integers(0, 0xFFFF),
    total_ticks=st.integers(0, 0xFFFF),
)


@given(controls, st.binary(max_size=40))
def test_request_object_round_trip(control: ControlWord, packet: bytes) -> None:
    request = Eth1394Request(control, packet)
    raw = build_request(request)
    assert len(raw) == CONTROL_WORD_SIZE + len(packet)
    assert parse_request(raw) == request


@given(extras, st.binary(max_size=40))
def test_response_object_round_trip(extra: ExtraBytes, packet: bytes) -> None:
    response = Eth1394Response(packet, extra)
    raw = build_response(response)
    assert len(raw) == len(packet) + EXTRA_SIZE
    assert parse_response(raw) == response
