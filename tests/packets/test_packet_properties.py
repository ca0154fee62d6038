"""Round trips and robustness of the codec, for every packet kind, with hypothesis."""

from __future__ import annotations

import contextlib
import dataclasses
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.fuzz.strategies import acks, async_packets, phy_packets
from fw1394.packets import (
    ASYNC_CLASSES,
    LAYOUTS,
    Ack,
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    PacketError,
    PhyPacket,
    QuadletReadRequest,
    QuadletWriteRequest,
    TCode,
    decode,
    encode,
    to_json,
)
from fw1394.packets.asynchronous import decode_async, stored_header_fields
from fw1394.packets.fast import (
    FIELD_NAMES,
    builder,
    decode_header,
    decode_packet,
    decode_sound,
    encode_packet,
    wire_builder,
)


def test_classes_declare_exactly_their_layout_fields() -> None:
    for tcode, cls in ASYNC_CLASSES.items():
        assert set(stored_header_fields(cls)) == set(LAYOUTS[tcode].fields), cls.__name__


@given(async_packets(max_data=64))
def test_parse_build_async(packet: AsyncPacket) -> None:
    assert decode(encode(packet)) == packet.with_crcs()


@given(async_packets(max_data=64))
def test_parse_build_async_without_crc(packet: AsyncPacket) -> None:
    assert decode(encode(packet, crc=False), crc=False, kind="async") == packet


@given(phy_packets())
def test_parse_build_phy(packet: PhyPacket) -> None:
    assert decode(encode(packet), kind="phy") == packet.with_inverse()
    assert type(decode(encode(packet, crc=False), crc=False, kind="phy")) is type(packet)


@given(acks())
def test_parse_build_ack(ack: Ack) -> None:
    assert decode(encode(ack)) == Ack(ack.code, ack.code ^ 0xF)


@given(async_packets(max_data=64, with_crc=True))
def test_build_parse_is_identity_on_valid_bytes(packet: AsyncPacket) -> None:
    wire = encode(packet)
    assert encode(decode(wire)) == wire


@given(st.binary(max_size=80))
@settings(max_examples=500)
def test_arbitrary_bytes_strict_only_packet_error(blob: bytes) -> None:
    with contextlib.suppress(PacketError):
        decode(blob)


@given(st.binary(max_size=80))
@settings(max_examples=500)
def test_arbitrary_bytes_lenient_is_a_flagged_packet(blob: bytes) -> None:
    try:
        packet = decode(blob, strict=False)
    except PacketError as error:
        # Only when no packet can be made: too short for a header, or no such tcode.
        assert error.field in ("length", "tcode", "identifier")
        return
    to_json(packet)  # every decoded packet can be shown
    try:
        decode(blob, strict=True)
    except PacketError as error:
        assert str(error) in [str(p) for p in packet.problems]
    else:
        assert not packet.problems


@given(async_packets(max_data=64, with_crc=True), st.integers(0, 7), st.integers(0, 7))
def test_a_flipped_bit_is_always_caught(packet: AsyncPacket, byte: int, bit: int) -> None:
    wire = bytearray(encode(packet))
    wire[byte] ^= 1 << bit
    try:
        damaged = decode(bytes(wire), strict=False)
    except PacketError:
        return  # the flip changed the tcode into one no layout has
    assert damaged.problems


@given(async_packets(max_data=64, with_crc=True))
def test_fast_path_equals_construct_path(packet: AsyncPacket) -> None:
    wire = encode(packet)
    values = dict(zip(FIELD_NAMES[int(packet.tcode)], decode_header(wire), strict=True))
    assert values.pop("tcode") == packet.tcode
    decoded = decode(wire)
    assert isinstance(decoded, AsyncPacket)
    expected = {**decoded.header_fields(), "header_crc": decoded.header_crc}
    del expected["tcode"]
    assert values == expected


def test_dataclass_values_are_immutable() -> None:
    packet = decode(bytes.fromhex("ffc0f140ffc1fffff00009845bdd119c"))
    assert isinstance(packet, QuadletReadRequest)
    try:
        packet.tlabel = 3  # type: ignore[misc]
    except dataclasses.FrozenInstanceError:
        return
    raise AssertionError("packets must be immutable")


@given(async_packets(max_data=64))
def test_fast_encode_equals_codec(packet: AsyncPacket) -> None:
    assert encode_packet(packet) == encode(packet)


@given(async_packets(max_data=64), st.data())
def test_wire_builder_equals_codec(packet: AsyncPacket, data: st.DataObject) -> None:
    # Any subset of the fields, in any order: the others take their defaults.
    layout = packet.LAYOUT
    settable = [n for n in layout.fields if not (layout.has_data and n == "data_length")]
    settable += ["data"] if layout.has_data else []
    names = data.draw(st.lists(st.sampled_from(settable), unique=True))
    values = {name: getattr(packet, name) for name in names}
    assert wire_builder(type(packet), *names)(*values.values()) == encode(type(packet)(**values))


def test_wire_builder_computes_what_it_is_not_told() -> None:
    read = ASYNC_CLASSES[TCode.read_block_response]
    with pytest.raises(TypeError, match="data_length is the length of data"):
        wire_builder(read, "data", "data_length")
    with pytest.raises(TypeError, match="header_crc"):
        wire_builder(read, "header_crc")


@given(async_packets(max_data=64))
def test_fast_decode_equals_codec_on_sound_packets(packet: AsyncPacket) -> None:
    wire = encode(packet)
    assert decode_packet(wire) == decode_async(wire)


@given(st.binary(max_size=80) | async_packets(max_data=16).map(encode).map(lambda b: b[:-1]))
@settings(max_examples=300)
def test_fast_decode_equals_codec_on_any_bytes(blob: bytes) -> None:
    try:
        expected = decode_async(blob)
    except PacketError as error:
        with pytest.raises(PacketError) as raised:
            decode_packet(blob)
        assert str(raised.value) == str(error)
        return
    assert decode_packet(blob) == expected


@given(st.binary(max_size=80) | async_packets(max_data=16).map(encode))
@settings(max_examples=300)
def test_decode_sound_is_strict_decode(blob: bytes) -> None:
    try:
        expected = decode_async(blob, strict=True)
    except PacketError:
        assert decode_sound(blob) is None
        return
    assert decode_sound(blob) == expected


@pytest.mark.parametrize(
    ("cls", "names", "values"),
    [
        (BlockWriteRequest, ("destination_id", "tlabel", "data"), (0xFFC0, 5, b"\x01\x02\x03")),
        (BlockWriteRequest, ("destination_id",), (0xFFC1,)),
        (BlockReadRequest, ("destination_id", "data_length"), (0xFFC0, 64)),
        (QuadletWriteRequest, ("destination_id", "quadlet_data"), (0xFFC2, 0xCAFEF00D)),
    ],
)
def test_a_builder_makes_what_the_constructor_makes(
    cls: type[AsyncPacket], names: tuple[str, ...], values: tuple[Any, ...]
) -> None:
    built = builder(cls, *names)(*values)
    assert built == cls(**dict(zip(names, values, strict=True)))
    data = getattr(built, "data", None)
    if data is not None and "data_length" not in names:
        assert built.data_length == len(data)  # type: ignore[attr-defined]
