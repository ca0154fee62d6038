"""Eth1394 datagram sizes derived from the layouts equal the JHU spec's and real datagrams'."""

from __future__ import annotations

from typing import Any

from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets import (
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    encode,
)
from fw1394.packets import eth1394 as e


def test_sizes_match_the_spec_table() -> None:
    # JHU Eth1394 spec: packet sizes 16 / 20 / 20 / 24+N for requests, 20 / 24+N for
    # responses, a 2-byte control word before requests and 8 extra bytes after responses.
    assert (e.CONTROL_WORD_SIZE, e.EXTRA_SIZE) == (2, 8)
    assert (e.QREAD_REQUEST_SIZE, e.QWRITE_REQUEST_SIZE, e.BREAD_REQUEST_SIZE) == (18, 22, 22)
    assert e.BWRITE_REQUEST_BASE_SIZE == 26
    assert (e.QUADLET_RESPONSE_SIZE, e.BLOCK_RESPONSE_BASE_SIZE) == (28, 32)
    assert e.BLOCK_PACKET_OVERHEAD == 24
    assert e.max_read_data_size(1500) == 1440


def _request(packet: bytes) -> bytes:
    control = e.ControlWord(bus_generation=0)
    return e.build_request(e.Eth1394Request(control, packet))


@given(st.integers(0, 63), st.binary(max_size=64).map(lambda b: b + bytes(-len(b) % 4)))
def test_sizes_equal_built_datagrams(tlabel: int, data: bytes) -> None:
    route: dict[str, Any] = {"destination_id": 0xFFC0, "source_id": 0xFFD0, "tlabel": tlabel}
    assert len(_request(encode(QuadletReadRequest(**route, offset=0)))) == e.QREAD_REQUEST_SIZE
    qwrite = encode(QuadletWriteRequest(**route, offset=0, quadlet_data=1))
    assert len(_request(qwrite)) == e.QWRITE_REQUEST_SIZE
    bread = encode(BlockReadRequest(**route, offset=0, data_length=len(data)))
    assert len(_request(bread)) == e.BREAD_REQUEST_SIZE
    bwrite = encode(BlockWriteRequest(**route, offset=0, data=data, data_length=len(data)))
    assert len(_request(bwrite)) == e.BWRITE_REQUEST_BASE_SIZE + len(data)
    quadlet = encode(QuadletReadResponse(**route, quadlet_data=7))
    block = encode(BlockReadResponse(**route, data=data, data_length=len(data)))
    assert len(quadlet) + e.EXTRA_SIZE == e.expected_response_size()
    assert len(block) + e.EXTRA_SIZE == e.expected_response_size(len(data))


def test_usable_write_size_is_the_largest_whole_quadlet_count() -> None:
    # Block writes carry whole quadlets: the usable size is the largest multiple of
    # 4 that fits, for every MTU (the raw limit is odd or even as the MTU is).
    for mtu in range(200, 1600):
        usable, limit = e.usable_write_data_size(mtu), e.max_write_data_size(mtu)
        assert usable % 4 == 0 and limit - 4 < usable <= limit, mtu
