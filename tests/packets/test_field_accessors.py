"""Generated one-field readers equal a full decode of the same packet."""

from __future__ import annotations

import struct

from hypothesis import given
from hypothesis import strategies as st

from fw1394.fuzz.strategies import async_packets, phy_packets
from fw1394.packets import LAYOUTS, AsyncPacket, PhyPacket, SelfIdPacket, decode, encode
from fw1394.packets.accessors import (
    ASYNC,
    OFFSET,
    PHY_IDENTIFIER,
    SELF_ID,
    SOURCE_ID,
    TCODE,
    TLABEL,
    layout_reader,
    readers,
)
from fw1394.packets.layouts import TCODE_BYTE, TCODE_SHIFT


def test_spec_example() -> None:
    # A quadlet read request from node 0xFFC1 to 0xFFC0, tlabel 5, at 0xFFFF_F000_0400.
    raw = bytes.fromhex("ffc01440 ffc1ffff f0000400")
    assert TCODE.of_bytes(raw) == 4
    assert TLABEL.of_bytes(raw) == 5
    assert SOURCE_ID.of_bytes(raw) == 0xFFC1
    assert OFFSET.of_bytes(raw) == 0xFFFF_F000_0400
    assert (TCODE.quadlet, TCODE.shift, TCODE.mask) == (0, 4, 0xF)
    assert TCODE.end == TCODE_BYTE + 1 and TCODE.shift == TCODE_SHIFT


def test_only_fields_placed_alike_everywhere_are_common() -> None:
    # data_length sits in quadlet 3 of block packets but quadlet 0 of stream packets.
    assert "data_length" not in ASYNC
    assert "header_crc" not in ASYNC
    assert {"tcode", "tlabel", "destination_id", "source_id", "rcode", "offset"} <= set(ASYNC)


@given(async_packets(max_data=32), st.binary(max_size=7))
def test_async_readers_equal_a_full_decode(packet: AsyncPacket, before: bytes) -> None:
    raw = encode(packet)
    decoded = decode(raw)
    layout = LAYOUTS[decoded.tcode]  # type: ignore[union-attr]
    quadlets = struct.unpack_from(f">{layout.sealed_header.count}I", raw)
    parsed = layout.sealed_header.parse(raw)  # the construct description, field by field
    for name in layout.sealed_header.names:
        if name == "reserved":
            continue
        expected = parsed[name]
        if name in layout.fields:
            assert getattr(decoded, name) == expected, name
        for reader in (ASYNC.get(name), layout_reader(decoded.tcode, name)):  # type: ignore[union-attr]
            if reader is None:
                continue
            assert reader.of_bytes(raw) == expected, name
            assert reader.of_bytes(before + raw, len(before)) == expected, name
            assert reader.of_bytes(memoryview(raw)) == expected, name
            assert reader(quadlets) == expected, name
            assert len(raw) >= reader.end


@given(st.sampled_from(sorted(LAYOUTS)), st.binary(min_size=48, max_size=48))
def test_readers_equal_construct_on_arbitrary_header_bits(tcode: int, noise: bytes) -> None:
    layout = LAYOUTS[tcode]  # type: ignore[index]
    raw = noise[: 4 * layout.sealed_header.count]
    parsed = layout.sealed_header.parse(raw)
    for name, reader in readers(layout.sealed_header).items():
        assert reader.of_bytes(raw) == parsed[name], name


@given(phy_packets())
def test_self_id_readers_equal_a_full_decode(packet: PhyPacket) -> None:
    raw = encode(packet)
    decoded = decode(raw, kind="phy")
    (quadlet,) = struct.unpack_from(">I", raw)
    assert PHY_IDENTIFIER.of_bytes(raw) == quadlet >> 30 == PHY_IDENTIFIER((quadlet,))
    if isinstance(decoded, SelfIdPacket):
        for name, reader in SELF_ID.items():
            if hasattr(decoded, name):
                assert reader.of_bytes(raw) == int(getattr(decoded, name)), name
                assert reader((quadlet,)) == int(getattr(decoded, name)), name
