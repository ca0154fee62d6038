"""QLA board parts at edges the register tests do not reach.

Facts from jhu-eth1394.md: STATUS bits 3:0 are the amplifier enables of axes 1-4
(bit n-1: axis n, §4); the hub's real-time block starts with the 49.152 MHz ticks
since the broadcast query (§4); a packet of another bus generation is dropped
unless it must not be forwarded (§2.7). The PROM instruction codes are the M25P16
data sheet's (bulk erase 0xC7, sector erase 0xD8, write enable 0x06); an
instruction the chip does not know does nothing.
"""

from __future__ import annotations

import pytest
from spec_crc import crc32_1394

from fw1394.boards.config_rom import with_config_rom
from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.ethernet import EthernetPort, Reply
from fw1394.boards.qla1.firewire import ClockedBoard, reaches_every_node
from fw1394.boards.qla1.hub import HubBlock, HubState
from fw1394.boards.qla1.paths import ETHERNET_PATH, FIREWIRE_PATH
from fw1394.boards.qla1.prom import ConfigProm
from fw1394.boards.qla1.regmap import REGISTER_MAP as QLA_MAP
from fw1394.boards.qla1.status import BoardControl
from fw1394.boards.snake2010.regmap import REGISTER_MAP as SNAKE2010_MAP
from fw1394.engine import JHU_FIRMWARE, Responder
from fw1394.engine.space import AddressError
from fw1394.packets import BlockWriteRequest, QuadletReadRequest
from fw1394.packets.nodeid import node_id

WRITE_ENABLE = 0x06


def test_an_amplifier_request_enables_the_bit_of_its_axis() -> None:
    for axis in (1, 2, 3, 4):
        control = BoardControl(power_enable=True)
        control.request_amp(axis, True)
        assert control.amps_enabled == 1 << (axis - 1)
        control.request_amp(axis, False)
        assert control.amps_enabled == 0


def test_a_kept_block_counts_its_ticks_from_the_query() -> None:
    hub = HubState(board_id=0)
    hub.query(1 << 16 | 0b11, now=1_000)
    made_elsewhere = HubBlock(sequence=1, update_ticks=7, quadlets=(1, 2, 3))
    hub.keep(1, made_elsewhere, now=1_500)
    assert hub.blocks[1].update_ticks == 500
    assert hub.blocks[1].quadlets == (1, 2, 3)


def test_an_instruction_the_prom_does_not_know_erases_nothing() -> None:
    prom = ConfigProm()
    prom.store(0x100, b"\x12\x34")
    for unknown in (0xE0, 0xFF):
        prom.command(WRITE_ENABLE << 24, now=0)
        prom.command(unknown << 24, now=0)
        assert prom.read_bytes(0x100, 2) == b"\x12\x34"


class _Bus:
    """A FireWire bus in generation 5, not resetting; the board is node 0."""

    node_id = 0
    generation = 5
    resetting = False


def _port() -> EthernetPort:
    board = Qla1Board(board_id=0, physical_id=0)
    return EthernetPort(board, Responder(node_id(0), ClockedBoard(board), JHU_FIRMWARE), _Bus())


#: jhu-eth1394.md §1.6: quadlet read of HW_VERSION (register 4) on node 0, tl=7.
QREAD_HW_VERSION = bytes.fromhex("ffc01c40ffd0000000000004a9927b79")


def test_a_request_of_another_generation_is_dropped_unless_it_must_not_be_forwarded() -> None:
    # §2.7: without NOFORWARD, a generation other than the FPGA's drops the packet and
    # a read is answered with the extra bytes alone; with NOFORWARD it is served.
    (dropped,) = _port().receive(b"\x00\x04" + QREAD_HW_VERSION, ("127.0.0.1", 5000), 0.0)
    assert isinstance(dropped, Reply) and dropped.packet == b""
    assert dropped.extra.packet_dropped
    (served,) = _port().receive(b"\x01\x04" + QREAD_HW_VERSION, ("127.0.0.1", 5000), 0.0)
    assert isinstance(served, Reply) and len(served.packet) == 20
    assert not served.extra.packet_dropped
    (current,) = _port().receive(b"\x00\x05" + QREAD_HW_VERSION, ("127.0.0.1", 5000), 0.0)
    assert isinstance(current, Reply) and len(current.packet) == 20


def test_the_snake2010_spots_hit_only_holes_of_its_map() -> None:
    # docs/boards/snake2010.md: global devices 5-15 are unmapped; the spots (addresses a
    # fuzzer hits besides the registers) are such holes and the decoder's edges.
    assert all(SNAKE2010_MAP.at(spot) is None for spot in SNAKE2010_MAP.spots)
    assert {5, 6, 7} <= set(SNAKE2010_MAP.spots)


def test_the_safety_relay_reads_back_on_with_its_feedback() -> None:
    # §4 STATUS: a write's bit 17 is the relay's mask and bit 16 its value; a read has
    # bit 16 relay on and bit 17 the relay's feedback.
    board = Qla1Board(board_id=0, physical_id=0)
    board.write_quadlet(0, 1 << 17 | 1 << 16)
    assert board.read_quadlet(0) >> 16 & 0b11 == 0b11
    board.write_quadlet(0, 1 << 17)
    assert board.read_quadlet(0) >> 16 & 0b11 == 0


def test_motor_config_reads_back_its_limit_and_enable_delay() -> None:
    # §4 MOTOR_CONFIG (channel register 11): current limit 15:0, amp-enable delay 23:16,
    # bit 24 current control available; a write sets the fields its bits 24/25 name.
    board = Qla1Board(board_id=0, physical_id=0, firmware=8)
    board.write_quadlet(0x1B, 1 << 25 | 1 << 24 | 0x5A << 16 | 0x1234)
    assert board.read_quadlet(0x1B) == 1 << 24 | 0x5A << 16 | 0x1234


def test_every_quadlet_of_the_qla_prom_buffer_window_answers() -> None:
    # A board answers every read; the window at 0x3100 is larger than the buffer.
    board = Qla1Board(board_id=0, physical_id=0)
    assert all(isinstance(board.read_quadlet(0x3100 + n), int) for n in range(0x100))


def test_a_dac_command_with_bit_24_puts_its_channel_in_voltage_mode() -> None:
    # §4 DAC (channel register 1): bit 31 valid, bit 24 voltage mode (QLA 1.5+).
    board = Qla1Board(board_id=0, physical_id=0)
    board.write_quadlet(0x11, 1 << 31 | 1 << 24 | 0x8000)
    assert board.channels[0].voltage_mode
    board.write_quadlet(0x11, 1 << 31 | 1 << 25 | 0x8000)
    assert not board.channels[0].voltage_mode


def test_a_status_write_reboots_only_with_its_mask() -> None:
    # §4 STATUS: bit 21 is the reboot mask, bit 20 its value (Rev 7+).
    assert BoardControl().command(1 << 21 | 1 << 20).reboot
    assert not BoardControl().command(1 << 20).reboot
    assert not BoardControl().command(1 << 21).reboot


def test_an_amplifier_is_on_only_on_its_own_axis() -> None:
    control = BoardControl(power_enable=True)
    control.request_amp(3, True)
    assert [control.amp_on(axis) for axis in (1, 2, 3, 4)] == [False, False, True, False]


def test_the_firewire_link_ignores_the_bus_id_and_the_ethernet_path_does_not() -> None:
    # §3.1: the FireWire link matches only the node bits 21:16; §3.2: over Ethernet the
    # destination bus must be 0x3FF.
    other_bus = QuadletReadRequest(destination_id=0x3FE << 6, tlabel=1, source_id=0xFFD0, offset=4)
    local_bus = QuadletReadRequest(destination_id=0xFFC0, tlabel=1, source_id=0xFFD0, offset=4)
    assert FIREWIRE_PATH.takes(other_bus, 0) and FIREWIRE_PATH.takes(local_bus, 0)
    assert not ETHERNET_PATH.takes(other_bus, 0) and ETHERNET_PATH.takes(local_bus, 0)


def test_the_configuration_rom_says_which_fpgas_have_ethernet() -> None:
    # §4 CSR/ROM: the GUID's low nibble is 0xE for an Ethernet build (FPGA V2 and V3),
    # 0xF otherwise (V1).
    rom_guid_high = 0xFFFF_F000_040C
    nibbles = {
        version: Qla1Board(board_id=2, physical_id=0, fpga_version=version).read_quadlet(
            rom_guid_high
        )
        & 0xF
        for version in (1, 2, 3)
    }
    assert nibbles == {1: 0xF, 2: 0xE, 3: 0xE}


def test_power_reads_back_enabled_with_motor_voltage_good() -> None:
    # §4 STATUS: a write's bit 19 is the power mask and bit 18 its value; a read has
    # bit 19 motor voltage good and bit 18 power enable.
    board = Qla1Board(board_id=0, physical_id=0)
    board.write_quadlet(0, 1 << 19 | 1 << 18)
    assert board.read_quadlet(0) >> 18 & 0b11 == 0b11
    board.write_quadlet(0, 1 << 19)
    assert board.read_quadlet(0) >> 18 & 0b11 == 0


def test_a_dac_command_enables_its_amplifier_rev_8() -> None:
    # §4 DAC: bit 31 valid, bit 29 enable mask, bit 28 enable (Rev 8+); STATUS bits 3:0
    # are the amplifiers enabled, bit n-1 for axis n.
    board = Qla1Board(board_id=0, physical_id=0, firmware=8)
    board.write_quadlet(0, 1 << 19 | 1 << 18)  # power on
    board.write_quadlet(0x21, 1 << 31 | 1 << 29 | 1 << 28 | 0x8000)
    assert board.read_quadlet(0) & 0xF == 0b0010
    board.write_quadlet(0x21, 1 << 31 | 1 << 29 | 0x8000)
    assert board.read_quadlet(0) & 0xF == 0


def test_every_quadlet_of_the_qla_prom_buffer_window_takes_a_write() -> None:
    board = Qla1Board(board_id=0, physical_id=0)
    for n in range(0x100):
        board.write_quadlet(0x3100 + n, 0x51000000 + n)
    assert board.read_quadlet(0x3100 + 3) == 0x51000003


def test_a_block_write_to_node_0_at_the_fake_broadcast_offset_reaches_every_node() -> None:
    # §1.7 and §3.1: a block write to node 0 at 0xFFFF_FFFF_0000 is active for every node.
    def block_write(offset: int) -> BlockWriteRequest:
        return BlockWriteRequest(
            destination_id=0xFFC0, tlabel=1, source_id=0xFFD0, offset=offset, data=bytes(8)
        )

    assert reaches_every_node(block_write(0xFFFF_FFFF_0000))
    for near in (0xFFFF_FFFE_FFFF, 0xFFFF_FFFF_0001, 0xFFFF_FFFF_0004):
        assert not reaches_every_node(block_write(near))


class _Tooled(MemorySpace):
    """A board with something of its own beyond the address space (a tool, say)."""

    def __init__(self) -> None:
        super().__init__(16)
        self.armed = "the board's"
        self.zeroed = "the board's too"


def test_a_rom_window_offers_what_its_board_offers_whatever_its_name() -> None:
    window = with_config_rom(_Tooled(), bus="lab", board_id=1, rank=1, model="memory")
    # Names before and after "board" in sort order alike.
    assert (window.armed, window.zeroed) == ("the board's", "the board's too")


#: jhu-eth1394.md §1.6: block read of node 0, offset 0, 128 bytes (the real-time block),
#: tl=39, generation 5, no-forward; and the same of the hub memory at 0x1000 (CRC here).
BREAD_RT_BLOCK = bytes.fromhex("0105ffc09c50ffd000000000000000800000fc9a49db")


def test_only_a_read_of_hub_memory_waits_for_the_boards_of_the_round() -> None:
    # A broadcast query names board 1, which has not reported: a read of the hub's
    # memory waits for it, a read of the board's own real-time block does not.
    port = _port()
    port.board.write_quadlet(0x1800, 1 << 16 | 0b10)
    (answer,) = port.receive(BREAD_RT_BLOCK, ("127.0.0.1", 5000), 0.0)
    assert isinstance(answer, Reply) and len(answer.packet) == 20 + 128 + 4
    header = bytes.fromhex("ffc09c50ffd0000000001000") + (128 << 16).to_bytes(4, "big")
    hub_read = b"\x01\x05" + header + crc32_1394(header).to_bytes(4, "big")
    assert port.receive(hub_read, ("127.0.0.1", 5000), 1.0) == []
    assert port.poll(1.0 + port.hub_read_wait / 2) == []  # still waiting
    (late,) = port.poll(1.0 + port.hub_read_wait)  # the wait is over: answered as it is
    assert isinstance(late, Reply) and len(late.packet) == 20 + 128 + 4


def test_a_status_write_asks_for_power_only_with_a_masked_power_or_amplifier_enable() -> None:
    # §4 STATUS: bit 19/18 power mask/value; (mask << 8) | state of the amplifiers.
    asks = [
        BoardControl().command(value).asks_for_power
        for value in (1 << 19 | 1 << 18, 1 << 18, 1 << 19, 0x0101, 0x0100, 0x0001)
    ]
    assert asks == [True, False, False, True, False, False]


def test_motor_status_reads_an_amplifier_on_from_firmware_8() -> None:
    # §4 MOTOR_STATUS (channel register 12, Rev 8+): bit 29 amp on, bit 28 enable requested.
    for firmware in (8, 9):
        board = Qla1Board(board_id=0, physical_id=0, firmware=firmware)
        board.write_quadlet(0, 1 << 19 | 1 << 18)  # power on
        board.write_quadlet(0x11, 1 << 31 | 1 << 29 | 1 << 28 | 0x8000)  # enable axis 1
        assert board.read_quadlet(0x1C) >> 28 & 0b11 == 0b11
        assert board.read_quadlet(0x2C) >> 28 & 0b11 == 0


def test_every_quadlet_of_the_rom_window_refuses_a_write() -> None:
    # IEEE 1212: the configuration ROM at 0xFFFF_F000_0400..07FF is read-only.
    window = with_config_rom(MemorySpace(4096), bus="lab", board_id=1, rank=1, model="memory")
    for offset in (0xFFFF_F000_0400, 0xFFFF_F000_0600, 0xFFFF_F000_07FC):
        with pytest.raises(AddressError, match="configuration ROM"):
            window.write_quadlet(offset, 0)


def test_the_qla_register_map_has_the_channel_registers_of_its_four_axes() -> None:
    # §4: a QLA has 4 channels (STATUS bits 31:28); channel n's registers are at n << 4.
    assert list(QLA_MAP.group("channel").copies) == [1, 2, 3, 4]
    assert [QLA_MAP.offset("DAC", axis) for axis in (1, 2, 3, 4)] == [0x11, 0x21, 0x31, 0x41]


def test_an_eth_status_write_clears_the_sticky_summary_error_only_with_bit_29() -> None:
    # §2.5, §3.2 and docs/boards/qla1.md: a request for another bus sets the sticky
    # summary error (extra byte 0 bit 3) until ETH_STATUS (register 12) is written with
    # bit 29.
    port = _port()
    foreign = bytes.fromhex("ff800c40ffd0000000000004")  # quadlet read, bus 0x3FE
    port.receive(b"\x01\x05" + foreign + crc32_1394(foreign).to_bytes(4, "big"), HOST, 0.0)
    assert port.summary_error

    def write_eth_status(value: int) -> None:
        header = bytes.fromhex("ffc00d00ffd000000000000c") + value.to_bytes(4, "big")
        port.receive(b"\x01\x05" + header + crc32_1394(header).to_bytes(4, "big"), HOST, 0.0)

    write_eth_status(1 << 30)
    assert port.summary_error
    write_eth_status(1 << 29)
    assert not port.summary_error


HOST = ("127.0.0.1", 5000)
