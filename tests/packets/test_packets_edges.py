"""Packet details pinned to the standard's numbers and bit layouts, written out here.

* IEEE 1394-1995, the ack codes: their two top bits say complete
  or pending (00), busy (01), tardy (10) or error (11).
* IEEE 1394-1995, packet headers: a node ID is a 10-bit bus ID and a 6-bit physical ID;
  tlabel is 6 bits.
* IEEE 1394-1995, self-ID packet #0 (port status 11 child, 10 parent, 01 not connected).
* IEEE 1394a-2000, extended PHY packets: the type codes.
* The JHU FPGA's extra bytes count 49.152 MHz ticks (spec: FPGA_TotalTime = v / 49.152e6).
"""

from __future__ import annotations

import pytest

from fw1394.packets import (
    AckCode,
    BlockWriteRequest,
    ExtendedTCode,
    LockRequest,
    PacketError,
    QuadletReadRequest,
    encode,
)
from fw1394.packets.ack import Ack
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.enums import PhyPacketType, PowerClass
from fw1394.packets.eth1394 import ExtraBytes
from fw1394.packets.fast import encode_packet
from fw1394.packets.fields import FieldSpec, Quadlets
from fw1394.packets.hextext import HexTextError, hex_bytes
from fw1394.packets.phy import (
    PhyConfigPacket,
    RemoteAccessPacket,
    SelfIdPacket,
    decode_phy,
    encode_phy,
)
from fw1394.packets.render import field_rows, hex_preview, summary


def test_extended_phy_packet_types_are_the_1394a_numbers() -> None:
    assert {t.name: t.value for t in PhyPacketType} == {
        "ping": 0x0,
        "remote_access_base": 0x1,
        "remote_reply_base": 0x3,
        "remote_access_paged": 0x5,
        "remote_reply_paged": 0x7,
        "remote_command": 0x8,
        "remote_confirmation": 0xA,
        "resume": 0xF,
    }


# The standard's ack codes and their class (the others are reserved).
ACK_CLASSES = {
    0x1: "complete", 0x2: "pending",
    0x4: "busy", 0x5: "busy", 0x6: "busy",
    0xB: "tardy",
    0xC: "error", 0xD: "error", 0xE: "error", 0xF: "error",
}  # fmt: skip


@pytest.mark.parametrize(("code", "kind"), ACK_CLASSES.items())
def test_an_ack_is_busy_or_an_error_by_its_two_top_bits(code: int, kind: str) -> None:
    ack = Ack(code)
    assert (ack.is_busy, ack.is_error) == (kind == "busy", kind == "error")
    assert AckCode(code).name.startswith("ack_" + ("busy" if kind == "busy" else ""))


def test_the_destination_node_is_the_low_six_bits_of_the_node_id() -> None:
    # Bus 0x2AB, node 0x2D: 0x2AB << 6 | 0x2D.
    request = QuadletReadRequest(destination_id=0xAAED, tlabel=1, offset=0)
    assert (request.destination_bus, request.destination_node) == (0x2AB, 0x2D)


def test_tlabel_63_encodes_into_its_six_bits_and_64_is_refused() -> None:
    raw = encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=63, offset=0))
    # Quadlet 0: destination_ID(16) tl(6) rt(2) tcode(4) pri(4); tcode 4.
    assert raw[:4] == (0xFFC0 << 16 | 63 << 10 | 4 << 4).to_bytes(4, "big")
    with pytest.raises(PacketError, match="tlabel"):
        encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=64, offset=0))
    # The engine's generated encoder: same bytes, same refusal.
    assert encode_packet(QuadletReadRequest(destination_id=0xFFC0, tlabel=63, offset=0)) == raw
    with pytest.raises(PacketError, match="tlabel"):
        encode_packet(QuadletReadRequest(destination_id=0xFFC0, tlabel=64, offset=0))


def test_a_data_block_shorter_than_its_data_length_is_a_problem() -> None:
    short = BlockWriteRequest(
        destination_id=0xFFC0, tlabel=1, offset=0, data=b"abcd", data_length=8
    )
    assert [p.field for p in short.problems] == ["data"]
    whole = BlockWriteRequest(
        destination_id=0xFFC0, tlabel=1, offset=0, data=b"abcd", data_length=4
    )
    assert whole.problems == ()


def test_fpga_total_time_is_in_49_152_mhz_ticks() -> None:
    assert ExtraBytes(total_ticks=49152).total_seconds == pytest.approx(1e-3)


def test_phy_packets_take_keyword_arguments_only() -> None:
    with pytest.raises(TypeError):
        SelfIdPacket(1)  # type: ignore[call-arg]


def self_id(phy: int, port0: int, port1: int, port2: int) -> bytes:
    quadlet = (
        0b10 << 30 | phy << 24 | 1 << 22 | 63 << 16 | 2 << 14 | port0 << 6 | port1 << 4 | port2 << 2
    )
    return quadlet.to_bytes(4, "big") + (quadlet ^ 0xFFFFFFFF).to_bytes(4, "big")


def test_self_id_ports_are_shown_by_their_status() -> None:
    packet = decode_phy(self_id(phy=1, port0=0b10, port1=0b11, port2=0b01))
    text = summary(packet)
    for shown in ("phy_id=1", "port0=parent", "port1=child", "port2=not_connected", "speed=S400"):
        assert shown in text.split()
    meanings = {row[0]: row[2] for row in field_rows(packet)}
    assert (meanings["port0"], meanings["port1"], meanings["port2"]) == (
        "parent",
        "child",
        "not_connected",
    )


def test_a_remote_access_port_is_a_port_number_not_a_port_status() -> None:
    packet = RemoteAccessPacket(phy_id=2, type=0x5, page=1, port=3, register=4)
    assert "port=3" in summary(packet).split()
    rows = {row[0]: (row[1], row[2]) for row in field_rows(packet)}
    assert rows["port"] == ("3", "")


def test_an_absent_crc_is_shown_as_absent() -> None:
    rows = {row[0]: row[1] for row in field_rows(QuadletReadRequest(destination_id=1, offset=0))}
    assert rows["header_crc"] == "absent"
    assert rows["offset"] == "0x0" and rows["tlabel"] == "0"


def test_hex_preview_shows_whole_quadlets_from_the_first_byte() -> None:
    assert hex_preview(bytes(range(6))) == "00010203 0405"
    assert hex_preview(bytes(range(40))) == (
        "00010203 04050607 08090a0b 0c0d0e0f ... (+6 quadlets)"
    )


@pytest.mark.parametrize("widths", [(16, 15), (16, 17), (8,)])
def test_a_layout_quadlet_must_hold_exactly_32_bits(widths: tuple[int, ...]) -> None:
    specs: list[FieldSpec] = [(f"f{i}", width) for i, width in enumerate(widths)]
    with pytest.raises(ValueError, match="32 bits"):
        Quadlets(specs)
    assert Quadlets([("a", 16), ("b", 16)], [("c", 32)]).count == 2


@pytest.mark.parametrize(
    ("extended_tcode", "argument_size"),
    [
        (ExtendedTCode.mask_swap, 4),
        (ExtendedTCode.compare_swap, 4),
        (ExtendedTCode.fetch_add, 0),
        (ExtendedTCode.little_add, 0),
        (ExtendedTCode.bounded_add, 4),
        (ExtendedTCode.wrap_add, 4),
    ],
)
def test_a_lock_request_is_its_argument_then_its_data(
    extended_tcode: ExtendedTCode, argument_size: int
) -> None:
    # IEEE 1394-1995 lock requests: fetch_add and little_add carry data_value
    # only; the others arg_value then data_value, each half of the block.
    block = bytes.fromhex("0000000100000002")
    if not argument_size:
        block = block[:4]
    request = LockRequest(
        destination_id=0xFFC0, tlabel=1, offset=0, extended_tcode=extended_tcode, data=block
    )
    assert request.argument == block[:argument_size]
    assert request.lock_data == block[argument_size:]


def crc32_1394(data: bytes) -> int:
    """IEEE 1394's CRC-32 (polynomial 0x04C11DB7, MSB first, preset and inverted ones)."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = (crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1
            crc &= 0xFFFFFFFF
    return crc ^ 0xFFFFFFFF


def block_write_bytes(data: bytes, data_crc_delta: int = 0) -> bytes:
    # dest 0xFFC0, tlabel 2, retry 0, tcode 1, pri 0; source 0xFFC1, offset 0xFFFFF0000400;
    # data_length, extended_tcode 0; then header CRC, data, data CRC.
    header = b"".join(
        q.to_bytes(4, "big")
        for q in (
            0xFFC0 << 16 | 2 << 10 | 1 << 4,
            0xFFC1 << 16 | 0xFFFF,
            0xF0000400,
            len(data) << 16,
        )
    )
    crc = (crc32_1394(data) + data_crc_delta) & 0xFFFFFFFF
    return header + crc32_1394(header).to_bytes(4, "big") + data + crc.to_bytes(4, "big")


def test_the_data_crc_is_checked_against_the_standards_crc() -> None:
    good = decode_async(block_write_bytes(b"\x01\x02\x03\x04"))
    assert good.data_crc_ok is True and good.header_crc_ok is True and good.problems == ()
    bad = decode_async(block_write_bytes(b"\x01\x02\x03\x04", data_crc_delta=1))
    assert bad.data_crc_ok is False
    assert [p.field for p in bad.problems] == ["data_crc"]
    assert QuadletReadRequest(destination_id=1, offset=0).data_crc_ok is None


def test_hex_text_fills_0x_quadlets_and_refuses_an_odd_digit_count() -> None:
    assert hex_bytes("0x1, ff 0a") == b"\x00\x00\x00\x01\xff\x0a"
    with pytest.raises(HexTextError, match="odd number"):
        hex_bytes("abc")


def test_power_classes_are_the_self_id_pwr_codes() -> None:
    # pwr field of self-ID packet #0: 0 none; 1-3 provide 15, 30, 45 W; 4 uses up to
    # 1 W from the bus; 5-7 use 1 W plus 2, 5 or 9 W more (3, 6, 10 W).
    assert [(c.value, c.name) for c in PowerClass] == [
        (0, "no_power"),
        (1, "provides_15W"),
        (2, "provides_30W"),
        (3, "provides_45W"),
        (4, "uses_1W"),
        (5, "uses_3W"),
        (6, "uses_6W"),
        (7, "uses_10W"),
    ]


def test_a_default_phy_config_packet_sets_the_gap_count_to_63() -> None:
    # 00, root_ID 0, R 0, T 1, gap_cnt 63 (its value after a bus reset), 16 zero bits;
    # then the check quadlet, the first one inverted.
    quadlet = 1 << 22 | 63 << 16
    assert encode_phy(PhyConfigPacket()) == (
        quadlet.to_bytes(4, "big") + (quadlet ^ 0xFFFFFFFF).to_bytes(4, "big")
    )
