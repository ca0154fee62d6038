"""QLA1 address decoding per path, as the FPGA does it (jhu-eth1394.md §1.7, §4.1).

The MAIN register space ignores offset bits 11..8 (FPGA1394V3.v:255, QLA.v:94-96),
so quadlet 0x104 reads 'QLA1' like register 4 does on hardware; over Ethernet only
offset bits 15..0 reach the register bus (EthernetIO.v:1249), so the configuration
ROM offset 0xFFFF_F000_0400 is MAIN register 0x400 there (STATUS, by the aliasing).
"""

from __future__ import annotations

from hypothesis import given
from hypothesis import strategies as st

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.rack import Rack
from fw1394.boards.qla1.regmap import REGISTER_MAP
from fw1394.boards.qla1.regs import QLA1_HARDWARE_VERSION
from fw1394.boards.regmap import ETHERNET, FIREWIRE
from fw1394.packets import QuadletReadRequest
from fw1394.packets.eth1394 import ControlWord, Eth1394Request, build_request, parse_response
from fw1394.packets.fast import decode_packet, encode_packet

ROM_HEADER_OFFSET = 0xFFFF_F000_0400
HOST = ("127.0.0.1", 40000)
STATUS_BOARD_3 = 0x4000_0000 | 3 << 24


def ethernet_read(rack: Rack, offset: int) -> int:
    """A no-forward quadlet read of board 3 over the rack's Ethernet port; the data."""
    request = QuadletReadRequest(destination_id=0xFFC3, tlabel=5, source_id=0xFFD0, offset=offset)
    payload = build_request(Eth1394Request(ControlWord(no_forward=True), encode_packet(request)))
    [(_, reply)] = rack.receive(0, payload, HOST, 0.0)
    response = decode_packet(parse_response(reply.packet + bytes(8)).packet)
    value: int = response.quadlet_data  # type: ignore[attr-defined]
    return value


def test_main_space_ignores_bits_11_to_8_on_both_paths() -> None:
    for path in (FIREWIRE, ETHERNET):
        assert REGISTER_MAP.decode(0x104, path) == 0x004
        assert REGISTER_MAP.decode(0xF14, path) == 0x014  # channel 1 ADC
        # Other spaces keep bits 11..8: hub memory 0x1100 is not 0x1000.
        assert REGISTER_MAP.decode(0x1100, path) == 0x1100


def test_quadlet_0x104_reads_qla1_like_register_4() -> None:
    board = Qla1Board(board_id=3)
    assert board.read_quadlet(0x104) == QLA1_HARDWARE_VERSION == 0x514C4131
    assert board.read_quadlet(0xA04) == QLA1_HARDWARE_VERSION
    rack = Rack([3], firmware=9)
    assert ethernet_read(rack, 0x104) == QLA1_HARDWARE_VERSION


def test_writes_alias_too() -> None:
    board = Qla1Board(board_id=3)
    board.write_quadlet(0x314, 0x801234)  # channel 1 ENC_LOAD through its alias
    assert board.read_quadlet(0x014) == 0x801234


def test_config_rom_offset_is_register_space_over_ethernet() -> None:
    board = Qla1Board(board_id=3)
    rom_header = board.read_quadlet(ROM_HEADER_OFFSET)
    assert rom_header >> 16 == 0x0404  # FireWire: the bus-info block header
    assert REGISTER_MAP.decode(ROM_HEADER_OFFSET, ETHERNET) == 0x0000
    assert REGISTER_MAP.decode(ROM_HEADER_OFFSET, FIREWIRE) == ROM_HEADER_OFFSET
    rack = Rack([3], firmware=9)
    assert ethernet_read(rack, ROM_HEADER_OFFSET) == STATUS_BOARD_3
    assert ethernet_read(rack, 0xFFFF_F000_0404) == QLA1_HARDWARE_VERSION


@given(st.integers(0, 0xFFFF))
def test_every_main_alias_reads_like_its_register(index: int) -> None:
    board = Qla1Board(board_id=3)
    if index >> 12 != 0:
        return
    assert board.read_quadlet(index) == board.read_quadlet(index & ~0x0F00)


def test_block_reads_outside_main_step_through_decoding() -> None:
    board = Qla1Board(board_id=3)
    # A hub block read crosses 0x1800 (the query register) like single reads do.
    block = board.read_block(0x17FF, 8)
    assert int.from_bytes(block[4:8], "big") == board.read_quadlet(0x1800)
