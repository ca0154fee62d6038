"""The judge's edges: the datagram size limit and the one-line evidence of a finding.

Wire sizes and packet bytes are written here from IEEE 1394-1995 §6.2 (a block
response is four header quadlets, the header CRC, the data padded to quadlets and
the data CRC; a quadlet read response is four header quadlets and the header CRC),
not taken from fw1394's encoder; ack and rcode names are the standard's.
"""

from __future__ import annotations

import struct

from spec_crc import crc32_1394

from fw1394.engine import Reply
from fw1394.fuzz.judge import describe, difference, visible
from fw1394.fuzz.reference import Certainty
from fw1394.fuzz.target import Observation, Visibility
from fw1394.packets import BlockReadResponse, QuadletReadResponse

ACK_COMPLETE, ACK_PENDING = 0x1, 0x2
RESP_ADDRESS_ERROR = 0x7
TCODE_READ_QUADLET_RESPONSE = 0x6


def quadlet_read_response_bytes(tlabel: int, rcode: int, value: int) -> bytes:
    header = struct.pack(
        ">IIII",
        0xFFC1 << 16 | tlabel << 10 | TCODE_READ_QUADLET_RESPONSE << 4,
        0xFFC0 << 16 | rcode << 12,
        0,
        value,
    )
    return header + struct.pack(">I", crc32_1394(header))


def block_response(size: int) -> BlockReadResponse:
    return BlockReadResponse(
        destination_id=0xFFC1, source_id=0xFFC0, tlabel=5, rcode=0, data=bytes(range(size))
    )


def test_a_response_one_byte_over_the_datagram_limit_is_hidden_and_one_at_it_is_shown() -> None:
    # 8 data bytes: 4 header quadlets + header CRC + 8 bytes + data CRC = 32 wire bytes.
    reply = Reply(ACK_PENDING, block_response(8), False)
    assert visible(reply, Visibility(max_response=32)).response == block_response(8)
    assert visible(reply, Visibility(max_response=31)).response is None
    # 9 data bytes pad to 12: 36 wire bytes.
    assert visible(Reply(ACK_PENDING, block_response(9), False), Visibility(max_response=33)) == (
        Reply(ACK_PENDING, None, False)
    )


def test_silence_and_a_bare_ack_are_named() -> None:
    assert describe(Observation(None, None, False)) == "silence"
    assert describe(Observation(ACK_COMPLETE, None, False)) == "ack_complete"


def test_response_bytes_are_decoded_with_their_rcode_and_undecodable_bytes_shown_raw() -> None:
    raw = quadlet_read_response_bytes(tlabel=5, rcode=RESP_ADDRESS_ERROR, value=0x12345678)
    text = describe(Observation(ACK_PENDING, raw, False))
    assert text.startswith("ack_pending + ")
    for part in ("tlabel=5", "destination=0xffc1", "source=0xffc0", "resp_address_error"):
        assert part in text
    assert "data=0x12345678" in text
    assert raw.hex() not in text
    assert describe(Observation(None, b"\x00\x01", False)) == "bytes 0001"


def test_a_concatenated_response_says_so() -> None:
    response = QuadletReadResponse(
        destination_id=0xFFC1, source_id=0xFFC0, tlabel=1, rcode=0, quadlet_data=1
    )
    assert describe(Reply(ACK_PENDING, response, True)).endswith(" (concatenated)")
    assert "concatenated" not in describe(Reply(ACK_PENDING, response, False))


def test_block_data_is_shown_up_to_sixteen_bytes() -> None:
    short, long = (
        describe(Reply(None, block_response(16), False)),
        describe(Reply(None, block_response(17), False)),
    )
    assert "data=" + bytes(range(16)).hex() + ")" in short
    assert "data=" + bytes(range(16)).hex() + "...)" in long
    assert "data_length=17 " in long


def test_a_concatenated_response_where_a_split_one_was_expected_is_a_tenure_error() -> None:
    response = QuadletReadResponse(
        destination_id=0xFFC1, source_id=0xFFC0, tlabel=1, rcode=0, quadlet_data=1
    )
    split, concatenated = Reply(ACK_PENDING, response, False), Reply(ACK_PENDING, response, True)
    for expected, observed in ((split, concatenated), (concatenated, split)):
        assert difference(
            expected, observed, Certainty.exact, Visibility(), node_bits_only=False
        ) == ("tenure")
    assert difference(split, split, Certainty.exact, Visibility(), node_bits_only=False) is None
