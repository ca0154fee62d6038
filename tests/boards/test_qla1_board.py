"""The QLA1 board personality against the numbers of the JHU reference notes.

Section numbers refer to the reference notes on the JHU host and firmware
(minimal register set 4.10, start-up 4.9, real-time blocks 4.5-4.6,
watchdog 4.7, hub 4.8 and 2.10).
"""

from __future__ import annotations

import pytest

from fw1394.boards.qla1.board import (
    DEFECT_HW_VERSION_SWAPPED,
    DEFECT_RT_WRITE_ANY_BOARD,
    DEFECT_STATUS_WRITE_STORED,
    DEFECT_UNMAPPED_ADDRESS_ERROR,
    DEFECT_WATCHDOG_DISABLED,
    Qla1Board,
)
from fw1394.boards.qla1.regs import ip_from_register, ip_to_register
from fw1394.engine.space import TICKS_PER_SECOND, AddressError, AddressSpace

STATUS, FW_PHY_REQ, FW_PHY_RESP, WATCHDOG = 0, 1, 2, 3
HW_VERSION, TEMP, FW_VERSION, DIGIN, IP_ADDR, ETH_STATUS, GIT_DESC = 4, 5, 7, 10, 11, 12, 15
ADC, DAC, ENC_LOAD, ENC_DATA, PERIOD, QTR1, QTR5, RUN = 0, 1, 4, 5, 6, 7, 9, 10
MOTOR_CONFIG, MOTOR_STATUS = 11, 12
WATCHDOG_TIMEOUT = 1 << 23
RELAY_ON = 1 << 16
POWER_ENABLE = 1 << 18
CSR_ROM = 0xFFFF_F000_0400
WATCHDOG_UNIT = 256  # ticks of 49.152 MHz per watchdog count


def words(data: bytes) -> list[int]:
    return [int.from_bytes(data[n : n + 4], "big") for n in range(0, len(data), 4)]


def pack(*values: int) -> bytes:
    return b"".join(value.to_bytes(4, "big") for value in values)


def channel(number: int, register: int) -> int:
    return number << 4 | register


def fpga_generation(eth_status: int) -> str:
    """The host's decode of ETH_STATUS (section 4.3)."""
    if eth_status == 0:
        return "V1"
    if eth_status & 0x80000000:
        return "V2"
    if eth_status >> 30 == 0b01:
        return "V3"
    return "V?"


def test_is_an_address_space() -> None:
    assert isinstance(Qla1Board(board_id=0), AddressSpace)


# -- 4.10 minimal register set ---------------------------------------------------------


@pytest.mark.parametrize("board_id", [0, 3, 15])
def test_minimal_register_set(board_id: int) -> None:
    board = Qla1Board(board_id=board_id, firmware=9, fpga_version=3)
    assert board.read_quadlet(STATUS) == 0x40000000 | board_id << 24
    assert board.read_quadlet(HW_VERSION) == 0x514C4131
    assert board.read_quadlet(FW_VERSION) == 9
    assert board.read_quadlet(ETH_STATUS) == 0x40B00000
    assert board.read_quadlet(GIT_DESC) == 0
    board.write_quadlet(IP_ADDR, 0x0100007F)  # accepted silently
    board.write_quadlet(FW_PHY_REQ, 0)


def test_unmapped_reads_return_zero() -> None:
    board = Qla1Board(board_id=1)
    for offset in (0x4000, 0x2000, 0x0050, 0x0F50, 0x9000, 0xB012):
        assert board.read_quadlet(offset) == 0
    strict = Qla1Board(board_id=1, defects=frozenset({DEFECT_UNMAPPED_ADDRESS_ERROR}))
    with pytest.raises(AddressError):
        strict.read_quadlet(0x4000)


def test_only_the_low_16_offset_bits_are_decoded() -> None:
    board = Qla1Board(board_id=2)
    assert board.read_quadlet(0x0001_0004) == 0x514C4131
    assert board.read_quadlet(0xFFFF_0000_0007) == 8


# -- 4.9 start-up sequence, register by register ----------------------------------------


@pytest.mark.parametrize(("fpga_version", "generation"), [(1, "V1"), (2, "V2"), (3, "V3")])
def test_startup_sequence(fpga_version: int, generation: str) -> None:
    board_id = 2
    board = Qla1Board(board_id=board_id, firmware=9, fpga_version=fpga_version)
    # 1: broadcast IP write (127.0.0.1 byte-reversed); firmware 9 adds the board id.
    board.write_quadlet(IP_ADDR, 0x0100007F)
    if fpga_version >= 2:
        assert ip_from_register(board.read_quadlet(IP_ADDR)) == "127.0.0.3"
    # 2: hardware version must be 'QLA1'.
    assert board.read_quadlet(HW_VERSION).to_bytes(4, "big") == b"QLA1"
    # 4: FW_PHY_REQ = 0 asks for PHY register 0.
    board.write_quadlet(FW_PHY_REQ, 0)
    assert board.read_quadlet(FW_PHY_RESP) >> 8 & 0xF == 0
    # 5 / 11: board id in STATUS bits 27..24.
    assert board.read_quadlet(STATUS) >> 24 & 0xF == board_id
    # 6 / 9: firmware version.
    assert board.read_quadlet(FW_VERSION) == 9
    # 7 / 10: ETH_STATUS tells the FPGA generation.
    assert fpga_generation(board.read_quadlet(ETH_STATUS)) == generation
    # 12: git description, 0 = print nothing.
    assert board.read_quadlet(GIT_DESC) == 0


def test_gap_count_exchange() -> None:
    board = Qla1Board(board_id=0, firmware=8)
    # 13: read PHY register 1; reg 2 = (1 << 8) + PHY register 1, gap count 63 at power-up.
    board.write_quadlet(FW_PHY_REQ, 1)
    answer = board.read_quadlet(FW_PHY_RESP)
    assert answer == (1 << 8) + 63
    assert answer & 0x3F == 63
    # Gap 63 makes the host write 0x1100 + gap(1 node) = 0x1100 + 5.
    board.write_quadlet(FW_PHY_REQ, 0x1100 + 5)
    assert board.read_quadlet(FW_PHY_REQ) == 0x1105
    board.write_quadlet(FW_PHY_REQ, 1)
    assert board.read_quadlet(FW_PHY_RESP) == (1 << 8) + 5


def test_ip_register_encoding() -> None:
    assert ip_to_register("127.0.0.1") == 0x0100007F
    assert ip_to_register("169.254.0.100") == 0x6400FEA9
    assert Qla1Board(board_id=0).read_quadlet(IP_ADDR) == 0xFFFFFFFF  # unassigned
    board = Qla1Board(board_id=4, firmware=8, ip_address="169.254.0.100")
    assert board.read_quadlet(IP_ADDR) == 0x6400FEA9
    board.write_quadlet(IP_ADDR, 0x0100007F)  # firmware 8: stored as written
    assert board.read_quadlet(IP_ADDR) == 0x0100007F


def test_qladisp_startup_writes() -> None:
    board = Qla1Board(board_id=0, firmware=9)
    for number in range(1, 5):
        board.write_quadlet(channel(number, ENC_LOAD), 0x800000 + 0x1000 * number)
    for command in (0x00020000, 0x00080000, 0x00000F00):
        board.write_quadlet(STATUS, command)
    assert board.read_quadlet(STATUS) == 0x40000000
    for number in range(1, 5):
        position = board.read_quadlet(channel(number, ENC_DATA)) & 0xFFFFFF
        assert position == 0x800000 + 0x1000 * number
        assert board.read_quadlet(channel(number, MOTOR_CONFIG)) >> 24 & 1 == 1


# -- 4.5 real-time block read ------------------------------------------------------------


@pytest.mark.parametrize(
    ("firmware", "quadlets"),
    [(1, 20), (4, 20), (6, 20), (7, 28), (8, 32), (9, 32)],
)
def test_rt_block_sizes(firmware: int, quadlets: int) -> None:
    board = Qla1Board(board_id=0, firmware=firmware)
    assert board.rt_read_quadlets == quadlets
    assert len(board.read_block(0, 4 * quadlets)) == 4 * quadlets


def prepared_board(firmware: int) -> Qla1Board:
    board = Qla1Board(board_id=6, firmware=firmware)
    for number in range(1, 5):
        board.write_quadlet(channel(number, ENC_LOAD), 0x800000 + 0x1000 * number)
    return board


@pytest.mark.parametrize("firmware", [7, 8, 9])
def test_rt_block_layout_rev7_and_later(firmware: int) -> None:
    board = prepared_board(firmware)
    block = words(board.read_block(0, 4 * board.rt_read_quadlets))
    assert block[1] == board.read_quadlet(STATUS) == 0x46000000
    assert block[2] == board.read_quadlet(DIGIN)
    assert block[3] & 0xFFFF == board.read_quadlet(TEMP)
    groups = [ADC, ENC_DATA, PERIOD, QTR1, QTR5, RUN] + ([MOTOR_STATUS] if firmware >= 8 else [])
    for group_number, register in enumerate(groups):
        for n in range(4):
            assert block[4 + 4 * group_number + n] == board.read_quadlet(channel(n + 1, register))
    assert block[8:12] == [0x801000, 0x802000, 0x803000, 0x804000]


def test_rt_block_layout_before_rev7() -> None:
    board = prepared_board(6)
    block = words(board.read_block(0, 80))
    assert block[1] == 0x46000000
    assert block[8:12] == [0x801000, 0x802000, 0x803000, 0x804000]
    for n in range(4):
        assert block[4 + n] == board.read_quadlet(channel(n + 1, ADC))
        assert block[12 + n] == board.read_quadlet(channel(n + 1, PERIOD))
        assert block[16 + n] == board.read_quadlet(channel(n + 1, QTR1))


def test_rt_timestamp_counts_ticks_since_previous_read_minus_one() -> None:
    board = Qla1Board(board_id=0)
    board.set_time(1000)
    assert words(board.read_block(0, 128))[0] == 1000 - 1
    board.set_time(1000 + 49_152)  # one millisecond later
    assert words(board.read_block(0, 128))[0] == 49_152 - 1


# -- 4.6 real-time block write -----------------------------------------------------------


def test_captured_rev8_rt_write() -> None:
    board = Qla1Board(board_id=0, firmware=9)
    board.write_block(0, pack(0x00000006, 0x80008000, 0x80008000, 0x80008000, 0x80008000, 0))
    for number in range(1, 5):
        assert board.read_quadlet(channel(number, DAC)) == 0x8000
    assert board.read_quadlet(STATUS) == 0x40000000


def rev8_block(board_id: int, dacs: list[int], control: int) -> bytes:
    return pack(board_id << 8 | 6, *dacs, control)


def test_rev8_rt_write_own_and_other_board() -> None:
    board = Qla1Board(board_id=3, firmware=8)
    board.write_block(0, rev8_block(5, [0x80001111] * 4, 0x00030000))
    assert board.read_quadlet(channel(1, DAC)) == 0x8000  # another board's block: ignored
    assert board.read_quadlet(STATUS) & RELAY_ON == 0
    board.write_block(0, rev8_block(3, [0x80001234, 0x80002345, 0x80003456, 0x80004567], 0x30000))
    dacs = [board.read_quadlet(channel(n, DAC)) for n in range(1, 5)]
    assert dacs == [0x1234, 0x2345, 0x3456, 0x4567]
    status = board.read_quadlet(STATUS)
    assert status & RELAY_ON  # control quadlet applied as a STATUS write
    assert status >> 24 & 0xF == 3


def test_rev8_broadcast_rt_write_picks_own_block() -> None:
    data = rev8_block(0, [0x80000100] * 4, 0) + rev8_block(1, [0x80000200] * 4, 0x30000)
    board0, board1 = Qla1Board(board_id=0), Qla1Board(board_id=1)
    # 0xFFFF_FFFF_0000: the "fake broadcast" offset aliases onto register 0.
    for board in (board0, board1):
        board.write_block(0xFFFF_FFFF_0000, data)
    assert board0.read_quadlet(channel(2, DAC)) == 0x0100
    assert board1.read_quadlet(channel(2, DAC)) == 0x0200
    assert not board0.read_quadlet(STATUS) & RELAY_ON
    assert board1.read_quadlet(STATUS) & RELAY_ON


def test_rev7_rt_write_board_id_in_dac_commands() -> None:
    board = Qla1Board(board_id=2, firmware=7)
    assert board.rt_write_quadlets == 5
    mine = [0x80000000 | 2 << 24 | 0x1000 * n for n in range(1, 5)]
    board.write_block(0, pack(*mine, 0x30000))
    assert [board.read_quadlet(channel(n, DAC)) for n in range(1, 5)] == [
        0x1000,
        0x2000,
        0x3000,
        0x4000,
    ]
    assert board.read_quadlet(STATUS) & RELAY_ON
    other = [0x80000000 | 7 << 24 | 0x0AAA] * 4
    board.write_block(0, pack(*other, 0x20000))
    assert board.read_quadlet(channel(1, DAC)) == 0x1000
    assert board.read_quadlet(STATUS) & RELAY_ON


def test_old_rt_write_is_four_dac_commands() -> None:
    board = Qla1Board(board_id=0, firmware=6)
    board.write_block(0, pack(0x80000011, 0x80000022, 0x80000033, 0x80000044))
    assert [board.read_quadlet(channel(n, DAC)) for n in range(1, 5)] == [0x11, 0x22, 0x33, 0x44]


# -- STATUS writes are masked commands ---------------------------------------------------


def test_status_write_is_a_command_not_a_value() -> None:
    board = Qla1Board(board_id=5)
    board.write_quadlet(STATUS, 0x00030000)  # close relays
    status = board.read_quadlet(STATUS)
    assert status != 0x00030000
    assert status >> 28 == 4 and status >> 24 & 0xF == 5
    assert status & RELAY_ON
    board.write_quadlet(STATUS, 0)  # no mask bit: nothing changes
    assert board.read_quadlet(STATUS) == status
    board.write_quadlet(STATUS, 0x00020000)  # open relays
    assert not board.read_quadlet(STATUS) & RELAY_ON


def test_power_and_amplifier_enables() -> None:
    board = Qla1Board(board_id=5)
    board.write_quadlet(STATUS, 0x00000F0F)  # amplifiers without power: refused
    assert board.read_quadlet(STATUS) & 0xF == 0
    board.write_quadlet(STATUS, 0x000C0000)  # power on
    assert board.read_quadlet(STATUS) & POWER_ENABLE
    board.write_quadlet(STATUS, 0x00000305)  # enable 1, mask 1 and 2 -> only 1
    status = board.read_quadlet(STATUS)
    assert status & 0xF == 0b0001
    assert status >> 8 & 0xF == 0b0001  # amplifier 1 reports "on"
    assert board.read_quadlet(channel(1, MOTOR_STATUS)) >> 29 & 1 == 1
    board.write_quadlet(STATUS, 0x00000F00)
    assert board.read_quadlet(STATUS) & 0xF == 0


def test_power_and_amplifiers_in_one_write_leave_amplifiers_off() -> None:
    # RTL reading: the enables test the power state from before the write.
    board = Qla1Board(board_id=0)
    board.write_quadlet(STATUS, 0x000C0F0F)
    assert board.read_quadlet(STATUS) & POWER_ENABLE
    assert board.read_quadlet(STATUS) & 0xF == 0


def test_unknown_defect_names_are_left_to_other_layers() -> None:
    board = Qla1Board(board_id=5, defects=frozenset({"bad-header-crc"}))
    assert board.read_quadlet(STATUS) == 0x45000000


def test_defect_stores_status_writes() -> None:
    board = Qla1Board(board_id=5, defects=frozenset({DEFECT_STATUS_WRITE_STORED}))
    board.write_quadlet(STATUS, 0x00030000)
    assert board.read_quadlet(STATUS) == 0x00030000  # board id gone, as warned in 4.10


def test_other_planted_defects() -> None:
    swapped = Qla1Board(board_id=0, defects=frozenset({DEFECT_HW_VERSION_SWAPPED}))
    assert swapped.read_quadlet(HW_VERSION) == 0x31414C51
    promiscuous = Qla1Board(board_id=3, defects=frozenset({DEFECT_RT_WRITE_ANY_BOARD}))
    promiscuous.write_block(0, rev8_block(5, [0x80001111] * 4, 0))
    assert promiscuous.read_quadlet(channel(1, DAC)) == 0x1111
    sleepy = Qla1Board(board_id=0, defects=frozenset({DEFECT_WATCHDOG_DISABLED}))
    sleepy.set_time(TICKS_PER_SECOND)
    assert not sleepy.read_quadlet(STATUS) & WATCHDOG_TIMEOUT


# -- 4.7 watchdog ------------------------------------------------------------------------


def powered_board() -> Qla1Board:
    board = Qla1Board(board_id=1)
    board.write_quadlet(STATUS, 0x000C0000)
    board.write_quadlet(STATUS, 0x00000F0F)
    assert board.read_quadlet(STATUS) & 0xF == 0xF
    return board


def test_watchdog_default_period_is_30_ms() -> None:
    board = Qla1Board(board_id=1)
    assert board.read_quadlet(WATCHDOG) == 0x1680
    assert 0x1680 * WATCHDOG_UNIT * 1000 == 30 * TICKS_PER_SECOND  # exactly 30 ms


def test_watchdog_timeout_disables_amplifiers() -> None:
    board = powered_board()
    period_ticks = 0x1680 * WATCHDOG_UNIT  # 30 ms after the last write at tick 0
    board.set_time(period_ticks)
    assert not board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT
    board.set_time(period_ticks + WATCHDOG_UNIT)  # RTL reading: one count past the period
    status = board.read_quadlet(STATUS)
    assert status & WATCHDOG_TIMEOUT
    assert status & 0xF == 0 and status >> 8 & 0xF == 0
    board.write_quadlet(STATUS, 0x00000F00)  # any other write: the flag stays
    assert board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT
    board.write_quadlet(STATUS, 0x000C0000)  # a power request clears it
    assert not board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT


def test_watchdog_is_fed_by_writes() -> None:
    board = powered_board()
    board.write_quadlet(WATCHDOG, 10)  # 10 counts = 52 us
    for step in range(1, 20):
        board.set_time(step * 5 * WATCHDOG_UNIT)
        board.write_block(0, rev8_block(1, [0x80008000] * 4, 0))
    assert not board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT
    last_write = 19 * 5 * WATCHDOG_UNIT
    board.set_time(last_write + 11 * WATCHDOG_UNIT)
    assert board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT


def test_rt_write_for_another_board_does_not_feed_the_watchdog() -> None:
    board = powered_board()
    board.write_quadlet(WATCHDOG, 10)
    board.set_time(8 * WATCHDOG_UNIT)
    board.write_block(0, rev8_block(9, [0x80008000] * 4, 0))
    board.set_time(11 * WATCHDOG_UNIT)
    assert board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT


def test_watchdog_period_zero_disables_it() -> None:
    board = powered_board()
    board.write_quadlet(WATCHDOG, 0)
    board.set_time(10 * TICKS_PER_SECOND)
    assert not board.read_quadlet(STATUS) & WATCHDOG_TIMEOUT
    assert board.read_quadlet(STATUS) & 0xF == 0xF


# -- 4.8 / 2.10 hub and the broadcast query ----------------------------------------------


def test_broadcast_query_one_board() -> None:
    board = Qla1Board(board_id=0, firmware=9)
    board.write_quadlet(0x1800, 1 << 16 | 0x0001)  # the captured query: sequence 1, mask 1
    assert board.read_quadlet(0x1800) == 0x00010001
    # Host fallback: block read of 0x1000, sum(32 + 1) + 1 = 34 quadlets = 136 bytes.
    hub = words(board.read_block(0x1000, 136))
    assert hub[0] >> 24 == 33  # block size including its header
    assert hub[0] >> 16 & 0xFF == 1  # low byte of the sequence
    assert not hub[0] & 0x8000  # no sequence mismatch
    assert hub[2] == board.read_quadlet(STATUS)
    data = board.broadcast_read_data()
    assert data is not None and len(data) == 136
    assert words(data)[:33] == hub[:33]


def test_broadcast_query_waits_for_every_masked_board() -> None:
    hub_board, other = Qla1Board(board_id=0), Qla1Board(board_id=1)
    query = 7 << 16 | 0b11
    for board in (hub_board, other):
        board.write_quadlet(0x1800, query)
    assert hub_board.broadcast_read_data() is None
    # Board 1's broadcast: {sequence, 0, quadlet count}, then its real-time block.
    block = other.read_block(0, 128)
    hub_board.write_block(0xFFFF_FF00_1000, pack(7 << 16 | 32) + block)
    data = hub_board.broadcast_read_data()
    assert data is not None and len(data) == 4 * (2 * 33 + 1)
    hub = words(data)
    assert hub[33] >> 24 == 33 and hub[33 + 2] >> 24 & 0xF == 1


def test_query_for_other_boards_stores_nothing() -> None:
    board = Qla1Board(board_id=0)
    board.write_quadlet(0x1800, 2 << 16 | 0b10)
    assert board.read_quadlet(0x1000) == 0
    assert board.broadcast_read_data() is None


# -- CSR / configuration ROM (byte-addressed window) -------------------------------------


def test_config_rom_bus_info_block() -> None:
    board = Qla1Board(board_id=0, firmware=7, fpga_version=2)
    rom = words(board.read_block(CSR_ROM, 4 * 22))
    # CRC values hard-coded in the firmware (FireWire.v, Ethernet build, board 0, firmware 7).
    assert rom[0] == 0x0404_8496
    assert rom[1] == int.from_bytes(b"1394", "big")
    assert rom[3] == 0xFA610E << 8 | 0 << 4 | 0xE
    assert rom[4] == 7
    assert rom[5] == 0x0005_9395  # root directory
    assert rom[11] == 0x0004_56C4  # "JHU LCSR"
    assert rom[16] == 0x0005_87B6  # "FPGA2/QLA", at 0x440
    assert rom[21] == int.from_bytes(b"A\0\0\0", "big")
    assert board.read_quadlet(CSR_ROM + 4) == rom[1]


def test_csr_node_ids() -> None:
    board = Qla1Board(board_id=0)
    board.set_physical_id(2)
    assert board.read_quadlet(0xFFFF_F000_0008) == 0x3FF << 22 | 2 << 16
    board.write_quadlet(FW_PHY_REQ, 0)
    assert board.read_quadlet(FW_PHY_RESP) >> 2 & 0x3F == 2  # physical id in PHY register 0


def test_old_rt_broadcast_write_each_board_takes_its_tagged_group() -> None:
    # Before Rev 8 the host tags every DAC command with the board id (bits 27..24) and
    # packs the groups of the boards in use, 4 quadlets each, into one broadcast (§4.6).
    board = Qla1Board(board_id=2, firmware=5)
    groups = [[0x80000000 | owner << 24 | 0x100 * owner + n for n in range(1, 5)]
              for owner in (0, 2, 3)]  # fmt: skip
    board.write_block(0xFFFF_FFFF_0000, pack(*groups[0], *groups[1], *groups[2]))
    assert [board.read_quadlet(channel(n, DAC)) for n in range(1, 5)] == [
        0x201,
        0x202,
        0x203,
        0x204,
    ]


@pytest.mark.parametrize(("firmware", "taken"), [(4, True), (6, True), (7, False), (8, False)])
def test_old_query_address_only_before_rev7(firmware: int, taken: bool) -> None:
    # The FireWire host sends the query to 0xFFFF_FFFF_000F when no board is Rev 7 or later.
    board = Qla1Board(board_id=0, firmware=firmware)
    board.write_quadlet(0xFFFF_FFFF_000F, 0x0102 << 16 | 1)
    assert board.read_quadlet(0x1800) == (0x01020001 if taken else 0)
