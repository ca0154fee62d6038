"""The ack byte: one encoder and decoder, agreeing with the construct layout and the Ack codec."""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets import Ack, decode, encode
from fw1394.packets.ack import ACK_BYTES, ACK_LAYOUT, ack_byte, ack_code, ack_parity_ok
from fw1394.packets.render import summary
from fw1394.transport.sansio import wire


def test_spec_examples() -> None:
    # IEEE 1394-1995 §6.2.4.8: ack_complete (1) is sent as 0x1E, ack_pending (2) as 0x2D.
    assert ack_byte(1) == 0x1E
    assert ack_byte(2) == 0x2D
    assert ack_code(0x1E) == 1 and ack_parity_ok(0x1E)
    assert not ack_parity_ok(0x1F)


@given(st.integers(0, 15))
def test_encoder_equals_construct_build_and_the_codec(code: int) -> None:
    byte = ack_byte(code)
    assert bytes([byte]) == ACK_LAYOUT.build({"code": code, "parity": code ^ 0xF})
    assert bytes([byte]) == encode(Ack(code))
    assert ACK_BYTES[code] == byte == wire.ack_byte(code)
    assert wire.AckPayload(byte, 0, 0).code == code


@given(st.integers(0, 0xFF))
def test_decoder_equals_construct_parse(byte: int) -> None:
    parsed = ACK_LAYOUT.parse(bytes([byte]))
    assert ack_code(byte) == parsed.code
    assert ack_parity_ok(byte) == (parsed.parity == parsed.code ^ 0xF)
    ack = decode(bytes([byte]), kind="ack", strict=False)
    assert isinstance(ack, Ack)
    assert ack.parity_ok == ack_parity_ok(byte)


@given(st.integers(-64, 64))
def test_encoder_keeps_the_low_four_bits_like_before(code: int) -> None:
    assert ack_code(ack_byte(code)) == code & 0xF


def test_the_summary_flags_bad_parity_only() -> None:
    # IEEE 1394-1995 §6.2.4.3: the check nibble is the code's complement.
    good = decode(bytes([0x1E]), kind="ack", strict=False)
    bad = decode(bytes([0x1F]), kind="ack", strict=False)
    assert isinstance(good, Ack) and isinstance(bad, Ack)
    assert summary(good) == "ack_complete"
    assert summary(bad) == "ack_complete [bad parity]"
