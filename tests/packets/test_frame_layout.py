"""Bus frame header and ack payload: struct formats and filter offsets derived from construct."""

from __future__ import annotations

import struct

import construct
import pytest
from construct import ConstError
from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets.bitfields import flatten
from fw1394.packets.frame import (
    ACK_FRAME,
    ACK_FRAME_FORMAT,
    FRAME_HEADER,
    FRAME_HEADER_FORMAT,
    FRAME_HEADER_SPANS,
    FRAME_HEADER_VALUES,
    FRAME_MAGIC,
    FRAME_PREFIX,
    FRAME_VERSION,
)
from fw1394.transport.media import bpf
from fw1394.transport.sansio import wire

u8 = st.integers(0, 0xFF)
u16 = st.integers(0, 0xFFFF)
u32 = st.integers(0, 0xFFFF_FFFF)
VALUES = ("kind", "tag", "sender", "generation", "sender_phy", "destination", "speed", "sequence")


def headers() -> st.SearchStrategy[dict[str, int]]:
    return st.fixed_dictionaries(
        {
            "kind": u8,
            "tag": u32,
            "sender": u32,
            "generation": u32,
            "sender_phy": u8,
            "destination": u8,
            "speed": u8,
            "sequence": u32,
        }
    )


def test_the_header_is_the_documented_24_bytes() -> None:
    # The byte table of docs/virtual-bus.md, written out independently.
    assert wire.HEADER_SIZE == 24 == FRAME_HEADER.sizeof()
    assert {name: offset for name, (offset, _) in FRAME_HEADER_SPANS.items()} == {
        "magic": 0,
        "version": 2,
        "kind": 3,
        "tag": 4,
        "sender": 8,
        "generation": 12,
        "sender_phy": 16,
        "destination": 17,
        "speed": 18,
        "reserved": 19,
        "sequence": 20,
    }
    assert FRAME_PREFIX == b"FW\x01"


@given(headers())
def test_struct_pack_equals_construct_build(fields: dict[str, int]) -> None:
    built = FRAME_HEADER.build(fields)
    packed = FRAME_HEADER_FORMAT.pack(
        FRAME_MAGIC, FRAME_VERSION, *(fields[n] for n in VALUES[:7]), 0, fields["sequence"]
    )
    assert packed == built
    assert wire.FrameHeader(*(fields[n] for n in VALUES)).pack() == built
    assert built.startswith(FRAME_PREFIX)


@given(headers(), u8)
def test_struct_unpack_equals_construct_parse(fields: dict[str, int], reserved: int) -> None:
    raw = bytearray(FRAME_HEADER.build(fields))
    raw[FRAME_HEADER_SPANS["reserved"][0]] = reserved  # receivers ignore it
    parsed = FRAME_HEADER.parse(bytes(raw))
    expected = tuple(parsed[n] for n in VALUES)
    assert FRAME_HEADER_VALUES.unpack_from(raw) == expected
    assert tuple(wire.parse_header(bytes(raw))) == expected
    assert parsed.reserved == reserved


@given(st.binary(min_size=3, max_size=3).filter(lambda b: b != FRAME_PREFIX), headers())
def test_a_foreign_prefix_is_refused_by_both(prefix: bytes, fields: dict[str, int]) -> None:
    raw = prefix + FRAME_HEADER.build(fields)[3:]
    with pytest.raises(ConstError):
        FRAME_HEADER.parse(raw)
    with pytest.raises(wire.FrameError):
        wire.parse_header(raw)


@given(u8, u8, u32, st.binary(max_size=16))
def test_ack_payload_struct_equals_construct(
    byte: int, tlabel: int, sequence: int, tail: bytes
) -> None:
    fields = {"ack_byte": byte, "tlabel": tlabel, "acked_sequence": sequence}
    built = ACK_FRAME.build(fields)
    assert ACK_FRAME_FORMAT.pack(byte, tlabel, 0, sequence) == built
    assert wire.AckPayload(byte, tlabel, sequence, tail).pack() == built + tail
    parsed = wire.parse_ack(built + tail)
    assert (parsed.ack_byte, parsed.tlabel, parsed.acked_sequence, parsed.concatenated) == (
        byte,
        tlabel,
        sequence,
        tail,
    )
    assert wire.ACK_PAYLOAD.size == ACK_FRAME.sizeof() == 8


def test_filter_offsets_are_the_layout_field_offsets() -> None:
    for name, offset in (
        ("kind", wire.KIND_OFFSET),
        ("tag", wire.TAG_OFFSET),
        ("sender", wire.SENDER_OFFSET),
        ("destination", wire.DESTINATION_OFFSET),
    ):
        assert offset == FRAME_HEADER_SPANS[name][0], name


@given(headers())
def test_each_filter_load_reads_its_field(fields: dict[str, int]) -> None:
    # Execute the loads as the kernel would: a UDP header, then the frame.
    packet = bytes(bpf.UDP_HEADER) + FRAME_HEADER.build(fields)
    sizes = {0x20: ">I", 0x28: ">H", 0x30: ">B"}
    for name in ("magic", "kind", "tag", "sender", "destination"):
        code, offset = bpf.load(name)
        (value,) = struct.unpack_from(sizes[code], packet, offset)
        assert value == (FRAME_MAGIC if name == "magic" else fields[name]), name


def test_the_program_loads_exactly_the_derived_offsets() -> None:
    program = bpf._program(tag=7, member_id=5, phy_id=2, drop_acks=True)
    loads = {(code, k) for code, _, _, k in program if code in (0x20, 0x28, 0x30)}
    assert loads == {bpf.load(n) for n in ("magic", "tag", "sender", "kind", "destination")}


@given(headers())
def test_the_station_receive_path_reads_what_the_layout_says(fields: dict[str, int]) -> None:
    # transport.station unpacks received headers with its own format; until it takes
    # HEADER_VALUES and HEADER_PREFIX from wire, both must read the same fields.
    from fw1394.transport import station

    raw = FRAME_HEADER.build(fields)
    assert station._PREFIX == wire.HEADER_PREFIX == raw[: len(wire.HEADER_PREFIX)]
    assert station._FIELDS.unpack_from(raw) == wire.HEADER_VALUES.unpack_from(raw)


def test_flattened_fields_span_their_bits() -> None:
    # A 16-bit field covers bits 15..0 of its two bytes; a bit struct's fields run
    # from the byte's most significant bit down, in declaration order.
    layout = construct.Struct(
        "word" / construct.Int16ub,
        "bits"
        / construct.BitStruct("high" / construct.BitsInteger(3), "low" / construct.BitsInteger(5)),
    )
    assert [
        (f.name, f.byte_offset, f.byte_size, f.msb, f.lsb, f.width) for f in flatten(layout)
    ] == [
        ("word", 0, 2, 15, 0, 16),
        ("bits.high", 2, 1, 7, 5, 3),
        ("bits.low", 2, 1, 4, 0, 5),
    ]
