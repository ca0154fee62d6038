"""The FPGA V3 Ethernet PHYs (RTL8211F) through the MDIO windows the host library uses.

Frames as FpgaIO builds them (jhu-eth1394.md §4.1: 0x41A0 / 0x42A0): a read is
``0x60000000 | phy << 23 | register << 18``, a write ``0x50020000 | phy << 23 |
register << 18 | data``; the window reads back ``busy 26..24, register 20..16, data
15..0``. Expected values are the RTL8211F's: identification 0x001C / 0xC916, page
select register 31 with power-up page 0xA42, the interrupt-enable register 18 that
fpgatest walks a bit through.
"""

from __future__ import annotations

import pytest

from fw1394.boards.qla1.board import Qla1Board

RTL8211F, GMII_CORE = 1, 8
PAGSR, INER, PHYSR = 31, 18, 26


def window(channel: int) -> int:
    return 0x40A0 | channel << 8


def read_phy(board: Qla1Board, channel: int, phy: int, register: int) -> tuple[bool, int]:
    """ReadRTL8211F_Register: frame, then idle and the register echoed, then data."""
    board.write_quadlet(window(channel), 0x60000000 | phy << 23 | register << 18)
    value = board.read_quadlet(window(channel))
    idle = value & 0x07000000 == 0
    return idle and (value >> 16 & 0x1F) == register, value & 0xFFFF


def write_phy(board: Qla1Board, channel: int, phy: int, register: int, data: int) -> None:
    board.write_quadlet(window(channel), 0x50020000 | phy << 23 | register << 18 | data)


@pytest.mark.parametrize("channel", [1, 2])
def test_identification_on_both_channels(channel: int) -> None:
    board = Qla1Board(board_id=0, fpga_version=3)
    assert read_phy(board, channel, RTL8211F, 2) == (True, 0x001C)
    assert read_phy(board, channel, RTL8211F, 3) == (True, 0xC916)
    assert read_phy(board, channel, 0, 2) == (True, 0x001C), "address 0 answers too"


def test_page_select_and_the_walking_bit_test() -> None:
    board = Qla1Board(board_id=0, fpga_version=3)
    assert read_phy(board, 1, RTL8211F, PAGSR) == (True, 0x0A42)
    for bit in range(16):
        write_phy(board, 1, RTL8211F, INER, 1 << bit)
        assert read_phy(board, 1, RTL8211F, INER) == (True, 1 << bit)
    # Registers 16-30 belong to a page: another page has its own register 18.
    write_phy(board, 1, RTL8211F, PAGSR, 0x0D08)
    assert read_phy(board, 1, RTL8211F, INER) == (True, 0)
    assert read_phy(board, 1, RTL8211F, 2) == (True, 0x001C), "IEEE registers on every page"
    write_phy(board, 1, RTL8211F, PAGSR, 0x0A42)
    assert read_phy(board, 1, RTL8211F, INER) == (True, 0x8000)


def test_channels_are_separate_and_status_reports_a_gigabit_link() -> None:
    board = Qla1Board(board_id=0, fpga_version=3)
    write_phy(board, 1, RTL8211F, INER, 0x1234)
    assert read_phy(board, 2, RTL8211F, INER) == (True, 0)
    ok, physr = read_phy(board, 2, RTL8211F, PHYSR)
    assert ok and physr & 0x0004 and physr & 0x0008 and physr >> 4 & 0x3 == 2
    ok, bmsr = read_phy(board, 1, RTL8211F, 1)
    assert ok and bmsr & 0x0004, "link status"


def test_identification_is_read_only_and_reset_restores_defaults() -> None:
    board = Qla1Board(board_id=0, fpga_version=3)
    write_phy(board, 1, RTL8211F, 2, 0xBEEF)
    assert read_phy(board, 1, RTL8211F, 2) == (True, 0x001C)
    write_phy(board, 1, RTL8211F, INER, 0x00FF)
    write_phy(board, 1, RTL8211F, 0, 0x8000)  # BMCR software reset
    assert read_phy(board, 1, RTL8211F, INER) == (True, 0)
    assert read_phy(board, 1, RTL8211F, 0) == (True, 0x1140)


def test_other_addresses_and_the_rgmii_core() -> None:
    board = Qla1Board(board_id=0, fpga_version=3)
    assert read_phy(board, 1, 5, 2) == (True, 0xFFFF), "nobody at address 5"
    write_phy(board, 1, GMII_CORE, 16, 0x0041)
    assert read_phy(board, 1, GMII_CORE, 16) == (True, 0x0041)


def test_no_phy_windows_before_fpga_v3() -> None:
    board = Qla1Board(board_id=0, fpga_version=2)
    write_phy(board, 1, RTL8211F, INER, 0x0001)
    assert board.read_quadlet(window(1)) == 0
