"""The hot-path Eth1394 framing (packets.eth1394_fast) equals the construct reference."""

from __future__ import annotations

from dataclasses import replace

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.boards.qla1.paths import zero_crc_bytes
from fw1394.packets import BlockReadResponse, QuadletReadResponse
from fw1394.packets.eth1394 import (
    ControlWord,
    Eth1394Error,
    Eth1394Request,
    Eth1394Response,
    ExtraBytes,
    build_request,
    build_response,
    parse_request,
)
from fw1394.packets.eth1394_fast import (
    extra_bytes,
    extra_generation_and_echo,
    request_datagram,
    split_request,
)
from fw1394.packets.fast import encode_packet

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
)


@given(st.binary(min_size=2, max_size=64))
def test_split_request_is_parse_request(payload: bytes) -> None:
    assert split_request(payload) == parse_request(payload)


def test_short_datagram_is_refused_alike() -> None:
    for payload in (b"", b"\x01"):
        with pytest.raises(Eth1394Error):
            split_request(payload)
        with pytest.raises(Eth1394Error):
            parse_request(payload)


@given(st.booleans(), st.integers(0, 255), st.binary(max_size=40))
def test_request_datagram_is_build_request(
    no_forward: bool, generation: int, packet: bytes
) -> None:
    control = ControlWord(no_forward=no_forward, bus_generation=generation)
    assert request_datagram(no_forward, generation, packet) == build_request(
        Eth1394Request(control, packet)
    )


@given(extras, st.integers(0, 0xFFFF), st.integers(0, 0xFFFF), st.binary(max_size=24))
def test_extra_bytes_are_build_response(
    extra: ExtraBytes, receive: int, total: int, packet: bytes
) -> None:
    timed = replace(extra, receive_ticks=receive, total_ticks=total)
    reference = build_response(Eth1394Response(packet, timed))
    assert packet + extra_bytes(extra, receive, total) == reference
    assert extra_generation_and_echo(reference) == (
        extra.fpga_bus_generation,
        extra.no_forward_echo,
    )


@given(
    st.integers(0, 63),
    st.integers(0, 0xFFFF),
    st.one_of(st.none(), st.binary(min_size=1, max_size=64)),
    st.integers(0, 0xFFFFFFFF),
)
def test_zero_crc_responses_are_the_packets_with_crcs_zero(
    tlabel: int, source: int, data: bytes | None, quadlet: int
) -> None:
    response: QuadletReadResponse | BlockReadResponse
    if data is None:
        response = QuadletReadResponse(
            destination_id=0xFFD0, tlabel=tlabel, source_id=source, quadlet_data=quadlet
        )
        reference = encode_packet(replace(response, header_crc=0))
    else:
        response = BlockReadResponse(
            destination_id=0xFFD0, tlabel=tlabel, source_id=source, reserved=0x1000, data=data
        )
        reference = encode_packet(replace(response, header_crc=0, data_crc=0))
    assert zero_crc_bytes(response) == reference
