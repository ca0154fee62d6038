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

import struct

import pytest
from construct import BitStruct, Int8ub, Int16ub, Int32ub, Nibble, Struct
from spec_crc import crc32_1394

from fw1394.crc import crc32
from fw1394.packets import (
    AckCode,
    BlockWriteRequest,
    ExtendedTCode,
    LockRequest,
    PacketError,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    decode,
    encode,
)
from fw1394.packets.accessors import SOURCE_ID, layout_reader
from fw1394.packets.ack import Ack
from fw1394.packets.asynchronous import CycleStart, StreamPacket, decode_async
from fw1394.packets.bitfields import flatten
from fw1394.packets.enums import PhyPacketType, PowerClass, RCode, Speed, TCode
from fw1394.packets.eth1394 import ExtraBytes, HostReadRequest, max_write_data_size
from fw1394.packets.fast import encode_packet
from fw1394.packets.fields import FieldSpec, Quadlets
from fw1394.packets.hextext import HexTextError, hex_bytes, quadlets_hex
from fw1394.packets.phy import (
    ExtendedSelfIdPacket,
    PhyConfigPacket,
    RemoteAccessPacket,
    RemoteCommandPacket,
    RemoteConfirmationPacket,
    SelfIdPacket,
    decode_phy,
    encode_phy,
)
from fw1394.packets.render import field_rows, hex_preview, summary, to_json


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
    values = {row[0]: row[1] for row in field_rows(packet)}
    assert (values["link_active"], values["contender"], values["inverse_ok"]) == ("yes", "no", "ok")
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


def test_a_block_write_request_takes_its_data_length_from_its_data_and_no_extended_tcode() -> None:
    request = BlockWriteRequest(destination_id=0xFFC0, offset=0, data=b"abcde")
    assert request.data_length == 5 and request.problems == ()
    # Header quadlet 3 of a block write: data_length(16), extended_tcode(16) = 0.
    assert encode(request)[12:16] == (5 << 16).to_bytes(4, "big")


def test_codes_are_the_standards_numbers() -> None:
    # IEEE 1394-1995 transaction, response and ack codes; extended tcodes of lock
    # requests; speed codes (S800 from 1394b).
    assert {c.name: c.value for c in TCode} == {
        "write_quadlet_request": 0x0,
        "write_block_request": 0x1,
        "write_response": 0x2,
        "read_quadlet_request": 0x4,
        "read_block_request": 0x5,
        "read_quadlet_response": 0x6,
        "read_block_response": 0x7,
        "cycle_start": 0x8,
        "lock_request": 0x9,
        "stream_data": 0xA,
        "lock_response": 0xB,
    }
    assert {c.name: c.value for c in RCode} == {
        "resp_complete": 0x0,
        "resp_conflict_error": 0x4,
        "resp_data_error": 0x5,
        "resp_type_error": 0x6,
        "resp_address_error": 0x7,
    }
    assert {c.name: c.value for c in AckCode} == {
        "ack_complete": 0x1,
        "ack_pending": 0x2,
        "ack_busy_X": 0x4,
        "ack_busy_A": 0x5,
        "ack_busy_B": 0x6,
        "ack_tardy": 0xB,
        "ack_conflict_error": 0xC,
        "ack_data_error": 0xD,
        "ack_type_error": 0xE,
        "ack_address_error": 0xF,
    }
    assert [c.value for c in ExtendedTCode] == [1, 2, 3, 4, 5, 6, 7]
    assert [(c.name, c.value) for c in Speed] == [
        ("S100", 0),
        ("S200", 1),
        ("S400", 2),
        ("S800", 3),
    ]


def test_field_readers_find_header_fields_at_their_standard_bytes() -> None:
    # A quadlet read response: quadlet 1 is source_ID(16) rcode(4) reserved(12), quadlet 3
    # the data; so source_ID is bytes 4-5, rcode the high nibble of byte 6, data bytes 12-15.
    raw = struct.pack(">IIII", 0xFFC1 << 16 | 5 << 10 | 6 << 4, 0xFFC2 << 16 | 7 << 12, 0, 0x1234)
    assert SOURCE_ID.byte_span == (4, 2, 0) and SOURCE_ID.of_bytes(raw) == 0xFFC2
    rcode, data = layout_reader(6, "rcode"), layout_reader(6, "quadlet_data")
    assert rcode.byte_span == (6, 1, 4) and rcode.of_bytes(raw) == 7
    assert data.byte_span == (12, 4, 0) and data.of_bytes(raw) == 0x1234
    response = decode_async(raw + bytes(4))
    assert isinstance(response, QuadletReadResponse)
    assert (response.source_bus, response.source_node) == (0x3FF, 2)


def test_a_responses_reserved_bits_rebuild_exactly() -> None:
    # IEEE 1394-1995 response header: quadlet 1 is source_ID(16) rcode(4) reserved(12),
    # quadlet 2 reserved(32). Bits a sender should leave zero still come back as they were.
    for low12, quadlet2 in ((0x001, 0), (0x800, 0x80000000), (0xABC, 0x12345678)):
        raw = struct.pack(">4I", 0xFFC11860, 0xFFC0 << 16 | low12, quadlet2, 0x514C4131)
        response = decode(raw, crc=False)
        assert isinstance(response, QuadletReadResponse)
        assert (response.source_id, response.quadlet_data) == (0xFFC0, 0x514C4131)
        assert encode(response, crc=False) == raw


def test_an_ack_whose_parity_was_computed_has_no_parity_complaint() -> None:
    # An ack built from its code alone (parity None: the complement is computed).
    assert summary(Ack(AckCode.ack_pending)) == "ack_pending"
    assert summary(Ack(AckCode.ack_pending, 0xD)) == "ack_pending"  # 0x2 complemented
    assert summary(Ack(AckCode.ack_pending, 0x2)) == "ack_pending [bad parity]"


def test_a_packet_without_a_data_block_has_no_data_keys() -> None:
    quadlet = to_json(QuadletReadRequest(destination_id=0xFFC0, offset=0xFFFFF0000400))
    assert {"data", "data_crc", "data_crc_ok"}.isdisjoint(quadlet)
    assert quadlet["header_crc_ok"] is None  # built, not received: no CRC to judge
    block = BlockWriteRequest(destination_id=0xFFC0, offset=0, data=b"abcd").with_crcs()
    assert to_json(block)["data_crc_ok"] is True


def test_a_host_read_request_takes_any_16_bit_block_length() -> None:
    # The 1394 block header's data_length is 16 bits.
    assert HostReadRequest(node=1, tl=2, data_length=0xFFFF).data_length == 0xFFFF
    assert HostReadRequest(node=1, tl=2, data_length=0x8000).data_length == 0x8000
    with pytest.raises(PacketError):
        HostReadRequest(node=1, tl=2, data_length=0x10000)


def test_packets_built_from_few_keywords_are_zero_where_the_standard_fixes_nothing() -> None:
    # Cycle start (tcode 8): a broadcast (0xFFFF) write of CYCLE_TIME (0xFFFF_F000_0200).
    start = encode(CycleStart(source_id=0xFFC0), crc=False)
    assert start == struct.pack(">4I", 0xFFFF0080, 0xFFC0FFFF, 0xF0000200, 0)
    # Asynchronous stream (tcode 0xA): data_length(16) tag(2) channel(6) tcode(4) sy(4).
    stream = encode(StreamPacket(data=b"\x01\x02\x03\x04"), crc=False)
    assert stream[:4] == struct.pack(">I", 4 << 16 | 0xA << 4)
    # Remote command (1394a): 00 phy_ID(6) 00 type(4)=8 000 port(4) 0(8) cmnd(3);
    # cmnd 0 is a NOP. Then the check quadlet, the first one inverted.
    quadlet = 5 << 24 | 0x8 << 18 | 2 << 11
    command = encode_phy(RemoteCommandPacket(phy_id=5, port=2))
    assert command == struct.pack(">II", quadlet, quadlet ^ 0xFFFFFFFF)


def test_a_remote_confirmation_with_its_reserved_bits_set_rebuilds_exactly() -> None:
    # 1394a remote confirmation: 00 phy_ID(6) 00 type(4)=0xA reserved(3) port(4) reserved(3)
    # fault connected bias disabled ok cmnd(3). Both reserved runs set, as received.
    quadlet = 3 << 24 | 0xA << 18 | 0b111 << 15 | 2 << 11 | 0b111 << 8 | 1 << 6 | 1 << 3 | 5
    raw = struct.pack(">II", quadlet, quadlet ^ 0xFFFFFFFF)
    confirmation = decode_phy(raw)
    assert isinstance(confirmation, RemoteConfirmationPacket)
    assert (confirmation.phy_id, confirmation.port, confirmation.command) == (3, 2, 5)
    assert confirmation.connected and not confirmation.fault
    assert encode_phy(confirmation) == raw


def test_a_nested_struct_flattens_at_its_byte_offsets() -> None:
    layout = Struct(
        "head" / Int16ub,
        "inner" / Struct("first" / Int8ub, "bits" / BitStruct("hi" / Nibble, "lo" / Nibble)),
        "tail" / Int32ub,
    )
    spans = [(f.name, f.byte_offset, f.byte_size, f.msb, f.width) for f in flatten(layout)]
    assert spans == [
        ("head", 0, 2, 15, 16),
        ("inner.first", 2, 1, 7, 8),
        ("inner.bits.hi", 3, 1, 7, 4),
        ("inner.bits.lo", 3, 1, 3, 4),
        ("tail", 4, 4, 31, 32),
    ]


def test_a_remote_command_with_its_reserved_bits_set_rebuilds_exactly() -> None:
    # 1394a remote command: 00 phy_ID(6) 00 type(4)=8 reserved(3) port(4) reserved(8) cmnd(3).
    quadlet = 3 << 24 | 0x8 << 18 | 0b110 << 15 | 2 << 11 | 0x81 << 3 | 4
    raw = struct.pack(">II", quadlet, quadlet ^ 0xFFFFFFFF)
    command = decode_phy(raw)
    assert isinstance(command, RemoteCommandPacket)
    assert (command.phy_id, command.port, command.command) == (3, 2, 4)
    assert encode_phy(command) == raw


def test_an_extended_self_id_built_from_few_keywords_lists_no_ports() -> None:
    # Self-ID packet #1: 10 phy_ID(6) 1 n(3) rsv(2) pa..ph (2 bits each) r(1) m(1);
    # port status 00 is "not present".
    quadlet = 0b10 << 30 | 5 << 24 | 1 << 23 | 1 << 20
    packet = ExtendedSelfIdPacket(phy_id=5, sequence=1)
    assert encode_phy(packet) == struct.pack(">II", quadlet, quadlet ^ 0xFFFFFFFF)


def test_quadlets_are_shown_as_eight_digits_with_a_short_tail() -> None:
    assert quadlets_hex(bytes(range(1, 10))) == "01020304 05060708 09"


def test_an_out_of_range_field_names_its_largest_value() -> None:
    with pytest.raises(PacketError, match=r"does not fit in 6 bits \(0\.\.0x3f\)"):
        encode(QuadletReadRequest(destination_id=0xFFC0, tlabel=64, offset=0))


def test_a_0x_quadlet_takes_up_to_eight_digits() -> None:
    assert hex_bytes("0x12345678 0x9") == bytes.fromhex("12345678 00000009")
    with pytest.raises(HexTextError):
        hex_bytes("0x123456789")


def test_every_phy_packet_kind_takes_keyword_arguments_only() -> None:
    for kind in (ExtendedSelfIdPacket, RemoteAccessPacket, RemoteCommandPacket):
        with pytest.raises(TypeError):
            kind(5)  # type: ignore[call-arg]


def test_a_paged_remote_access_is_a_remote_access() -> None:
    # 1394a remote access: 00 phy_ID(6) 00 type(4) page(3) port(4) reg(3) reserved(8);
    # type 1 reads a base register, type 5 a paged one.
    for kind in (0x1, 0x5):
        quadlet = 4 << 24 | kind << 18 | 1 << 15 | 2 << 11 | 3 << 8
        packet = decode_phy(struct.pack(">II", quadlet, quadlet ^ 0xFFFFFFFF))
        assert isinstance(packet, RemoteAccessPacket)
        assert (packet.phy_id, packet.page, packet.port, packet.register) == (4, 1, 2, 3)


def test_async_packets_take_keyword_arguments_only() -> None:
    for kind in (QuadletReadRequest, QuadletWriteRequest, BlockWriteRequest):
        with pytest.raises(TypeError):
            kind(0xFFC0)  # type: ignore[call-arg]


def test_on_loopback_a_block_write_carries_2024_bytes() -> None:
    # Spec: the host's write limit is min(2048, MTU - 28 - 2) - 24: 1446 at MTU 1500,
    # and on lo (MTU 65536) the 2048-byte packet limit rules: 2024.
    assert max_write_data_size(1500) == 1446
    assert max_write_data_size(65536) == 2024


def test_a_self_id_summary_names_the_flags_that_are_set() -> None:
    shown = summary(SelfIdPacket(phy_id=1, link_active=True, contender=False))
    assert "link_active" in shown.split() and "contender" not in shown


def test_a_block_cut_after_its_data_keeps_exactly_its_data() -> None:
    # Block write request of 5 data bytes cut inside its padding: no data CRC (what a
    # truncated capture holds).
    head = struct.pack(">4I", 0xFFC00410, 0xFFC1FFFF, 0xF0000400, 5 << 16)
    raw = head + struct.pack(">I", crc32(head)) + b"abcde" + bytes(2)
    packet = decode(raw, strict=False)
    assert isinstance(packet, BlockWriteRequest) and packet.data == b"abcde"
    assert packet.problems
