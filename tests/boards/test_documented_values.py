"""The QLA board's registers read back the values the JHU documentation gives.

Every expected value below is typed from the spec of the JHU Ethernet/FireWire
boards (§4.2 board registers, §4.3 FPGA generation, §4.4 channel registers,
the CSR and configuration-ROM paragraph), not from fw1394's register map: a map
and an emulator that agree on a wrong value pass the map's own tests, not
these.
"""

from __future__ import annotations

import pytest

from fw1394.boards import make_board
from fw1394.engine.space import AddressSpace

QLA1 = 0x514C4131  # "QLA1", §4.2 HARDWARE_VERSION
CHANNELS = 4
ROM = 0xFFFF_F000_0400


def qla(board_id: int, **options: int) -> AddressSpace:
    return make_board("qla1", board_id=board_id, **options)


@pytest.mark.parametrize("board_id", [0, 5, 15])
def test_status_carries_the_channel_count_and_board_id(board_id: int) -> None:
    status = qla(board_id).read_quadlet(0)
    assert status >> 28 == CHANNELS  # bits 31:28
    assert status >> 24 & 0xF == board_id  # bits 27:24
    assert not status & 1 << 23  # no watchdog timeout at power-up


def test_board_registers_at_power_up() -> None:
    board = qla(3, firmware=9)
    assert board.read_quadlet(4) == QLA1
    assert board.read_quadlet(3) == 0x1680  # watchdog: 30 ms in 5.208 us units
    assert board.read_quadlet(7) == 9  # FIRMWARE_VERSION as built
    assert board.read_quadlet(11) == 0xFFFF_FFFF  # IP_ADDR unassigned
    eth_status = board.read_quadlet(12)
    assert eth_status >> 30 == 0b01  # §4.3: bits 31:30 = 01 is an FPGA V3


@pytest.mark.parametrize("channel", range(1, CHANNELS + 1))
def test_encoders_start_at_midrange(channel: int) -> None:
    # §4.4: ENC_DATA is a 24-bit position whose midrange, 0x800000, is zero.
    assert qla(1).read_quadlet(channel << 4 | 5) & 0xFFFFFF == 0x800000


def test_unmapped_addresses_read_zero() -> None:
    board = qla(1)
    for address in (0x777, 0x5F, 0x0FF0):
        assert board.read_quadlet(address) == 0


def test_configuration_rom_bus_info_block() -> None:
    board = qla(6)
    # §4 CSR/ROM: header {4, 4, crc}, "1394", 0x00FFA000, {0xFA610E, board id, 0xE or 0xF}.
    header = board.read_quadlet(ROM)
    assert header >> 24 == 4 and header >> 16 & 0xFF == 4
    assert board.read_quadlet(ROM + 4) == 0x3133_3934
    assert board.read_quadlet(ROM + 8) == 0x00FF_A000
    guid_high = board.read_quadlet(ROM + 12)
    assert guid_high >> 8 == 0xFA610E and guid_high >> 4 & 0xF == 6
    assert guid_high & 0xF in (0xE, 0xF)
    crc = 0
    for index in range(1, 5):  # IEEE 1212 CRC-16 over the four quadlets after the header
        quadlet = board.read_quadlet(ROM + 4 * index)
        for shift in (28, 24, 20, 16, 12, 8, 4, 0):
            total = ((crc >> 12) ^ (quadlet >> shift)) & 0xF
            crc = ((crc << 4) ^ (total << 12) ^ (total << 5) ^ total) & 0xFFFF
    assert header & 0xFFFF == crc
