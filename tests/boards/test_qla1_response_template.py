"""A block read response built on a header encoded once is the response encoded whole.

The Ethernet path sends block read responses with both CRC quadlets 0 (jhu-eth1394.md
§3.2): the header (tcode 7) is written out here from the spec's field positions
(IEEE 1394 asynchronous block response), independently of fw1394's encoder.
"""

from __future__ import annotations

import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.qla1.paths import zero_crc_block_response, zero_crc_bytes
from fw1394.boards.qla1.rack import Rack
from fw1394.packets import BlockReadRequest, BlockReadResponse
from fw1394.packets.eth1394_fast import request_datagram
from fw1394.packets.fast import encode_packet

READ_BLOCK_RESPONSE = 0x7


def spec_response(destination: int, tlabel: int, source: int, q2: int, data: bytes) -> bytes:
    """Quadlets 0-3 by hand, a zero header CRC, the data padded to quadlets, a zero data CRC."""
    head = struct.pack(
        ">4I",
        destination << 16 | tlabel << 10 | READ_BLOCK_RESPONSE << 4,
        source << 16,  # rcode 0: complete
        q2,
        len(data) << 16,
    )
    padded = data + bytes(-len(data) % 4)
    return head + bytes(4) + padded + bytes(4)


@settings(max_examples=300, deadline=None)
@given(
    st.integers(0, 0xFFFF),
    st.integers(0, 0x3F),
    st.integers(0, 0xFFFF),
    st.integers(0, 0xFFFFFFFF),
    st.binary(max_size=120),
)
def test_the_template_is_the_whole_encoding(
    destination: int, tlabel: int, source: int, q2: int, data: bytes
) -> None:
    whole = zero_crc_bytes(
        BlockReadResponse(
            destination_id=destination, tlabel=tlabel, source_id=source, reserved=q2, data=data
        )
    )
    made = zero_crc_block_response(destination, tlabel, source, q2, data)
    assert made == whole == spec_response(destination, tlabel, source, q2, data)
    # The same header again, other data behind it: nothing of the first data stays.
    other = bytes(reversed(data))
    assert zero_crc_block_response(destination, tlabel, source, q2, other) == spec_response(
        destination, tlabel, source, q2, other
    )


def test_a_block_read_over_ethernet_answers_from_the_board_id() -> None:
    """With no-forward, the answer names {the request's bus, the board ID} (§3.2), not the
    board's FireWire node: board 9 sits at physical ID 1 of this rack."""

    rack = Rack([5, 9], firmware=9)
    request = BlockReadRequest(
        destination_id=0xFFC0 | 9, tlabel=17, source_id=0xFFD0, offset=0, data_length=16
    )
    [(index, reply)] = rack.receive(1, request_datagram(True, 0, encode_packet(request)),
                                    ("127.0.0.1", 40000), 0.001)  # fmt: skip
    q0, q1, q2, q3, header_crc = struct.unpack_from(">5I", reply.packet)
    assert index == 1
    assert q0 == 0xFFD0 << 16 | 17 << 10 | READ_BLOCK_RESPONSE << 4
    assert q1 == (0xFFC0 | 9) << 16  # source {bus 0x3FF, node 9}, rcode complete
    assert (q2, q3, header_crc) == (0, 16 << 16, 0)
    assert len(reply.packet) == 20 + 16 + 4 and reply.packet[-4:] == bytes(4)
