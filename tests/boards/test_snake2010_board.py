"""Register-level tests of the 2010 snake-board emulator against the thesis.

Numbers come from the thesis: Table 1 (addresses), Table 2 (status bits),
section 6.3 (watchdog: 49.152 MHz / 256 units, 16 bits, 0 = off), section
6.4 (valid bits), section 7.2 (14-bit signed ADC over 0..2.5 V, 16-bit DAC,
24-bit encoder with overflow, 768 kHz period counter, equation (1)).
"""

from __future__ import annotations

import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards import BOARDS, make_board
from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.engine.space import AddressSpace, DataError

CLOCK_HZ = 49_152_000
MS = CLOCK_HZ // 1000
WATCHDOG_UNIT = 256  # 5.2083 us expressed in clocks
VALID = 1 << 31
CURRENT_LIMIT = 1 << 16  # DAC B select bit of the DAC quadlet (documented)


def reg(channel: int, device: int) -> int:
    """Table 1: channel in bits 7-4, device in bits 3-0."""
    return channel << 4 | device


ADC, DAC, POT_CONTROL, POT_DATA, PRELOAD, ENCODER, PERIOD, FREQUENCY = range(8)
STATUS, PHY_CONTROL, PHY_DATA, WATCHDOG, VERSION = range(5)


def enable(board: Snake2010Board, amplifiers: int) -> None:
    """Switch the amplifiers in ``amplifiers`` on, leave the others alone."""
    board.write_quadlet(STATUS, amplifiers << 8 | amplifiers)


def signed14(half: int) -> int:
    half &= 0x3FFF
    return half - 0x4000 if half & 0x2000 else half


def pot_half(word: int) -> int:
    return signed14(word >> 16)


def current_half(word: int) -> int:
    return signed14(word & 0xFFFF)


def encoder_count(board: Snake2010Board, channel: int) -> int:
    return board.read_quadlet(reg(channel, ENCODER)) & 0xFFFFFF


def pot_frame(command: int, address: int = 0, data: int = 0) -> int:
    return command << 20 | address << 16 | data


@pytest.fixture
def board() -> Snake2010Board:
    return Snake2010Board(board_id=0xA)


# --- registry --------------------------------------------------------------


def test_registry_builds_address_spaces() -> None:
    for kind in ("snake2010", "snake2010-ztheta"):
        node = make_board(kind, board_id=1)
        assert isinstance(node, AddressSpace)
    ztheta = make_board("snake2010-ztheta", board_id=1)
    assert isinstance(ztheta, Snake2010Board)
    assert len(ztheta.channels) == 4


def test_registry_rejects_unknown_kind_listing_known_ones() -> None:
    with pytest.raises(KeyError, match="snake2010"):
        make_board("no-such-board", board_id=0)
    assert "snake2010" in BOARDS


def test_board_id_must_fit_the_rotary_switch() -> None:
    with pytest.raises(ValueError):
        Snake2010Board(board_id=16)


# --- Table 2: status register ---------------------------------------------


def test_status_reports_board_id_in_bits_27_to_24(board: Snake2010Board) -> None:
    status = board.read_quadlet(STATUS)
    assert status >> 24 & 0xF == 0xA
    assert status >> 28 == 0  # unused
    assert status & 0xFF == 0  # every amplifier off at power-up
    assert not status & 1 << 23


def test_status_write_changes_only_masked_amplifiers(board: Snake2010Board) -> None:
    board.write_quadlet(STATUS, 0b1010101 << 8 | 0b1010101)  # 1, 3, 5, 7 on
    assert board.read_quadlet(STATUS) & 0xFF == 0b1010101
    board.write_quadlet(STATUS, 0b0000111 << 8 | 0b0000010)  # 1, 3 off, 2 on
    assert board.read_quadlet(STATUS) & 0xFF == 0b1010010
    board.write_quadlet(STATUS, 0x00FF)  # enables without mask: nothing moves
    assert board.read_quadlet(STATUS) & 0xFF == 0b1010010
    assert board.read_quadlet(STATUS) >> 8 & 0xFF == 0  # mask is write-only


def test_fault_flags_sit_in_bits_22_to_16_and_leds_follow(board: Snake2010Board) -> None:
    enable(board, 0b111)
    board.set_amplifier_fault(3, True)
    status = board.read_quadlet(STATUS)
    assert status >> 16 & 0x7F == 0b100
    assert status & 0xFF == 0b111  # the enable stays as commanded
    assert board.leds == (True, True, False, False, False, False, False)
    board.set_amplifier_fault(3, False)
    assert board.read_quadlet(STATUS) >> 16 & 0x7F == 0
    assert board.leds[:3] == (True, True, True)


def test_faulted_amplifier_does_not_drive_its_motor(board: Snake2010Board) -> None:
    board.write_quadlet(reg(1, DAC), VALID | 0xC000)
    board.set_amplifier_fault(1, True)
    enable(board, 0b1)
    board.set_time(50 * MS)
    assert encoder_count(board, 1) == 0
    assert board.axis_state(1).current_amps == 0.0


def test_defect_write_ignores_mask() -> None:
    buggy = Snake2010Board(board_id=0, defects=frozenset({"write-ignores-mask"}))
    enable(buggy, 0b11)
    buggy.write_quadlet(STATUS, 0b100 << 8 | 0b100)  # only asks for amplifier 3
    assert buggy.read_quadlet(STATUS) & 0xFF == 0b100  # 1 and 2 lost their enable


# --- Table 1: global registers -----------------------------------------------


def test_phy_registers_read_and_write_through_the_window(board: Snake2010Board) -> None:
    board.write_quadlet(PHY_CONTROL, 1 << 8)  # read PHY register 1
    assert board.read_quadlet(PHY_DATA) == 1 << 8 | 0x3F  # gap count 63 at reset
    board.write_quadlet(PHY_CONTROL, 1 << 12 | 1 << 8 | 0x05)  # write gap count 5
    board.write_quadlet(PHY_CONTROL, 1 << 8)
    assert board.read_quadlet(PHY_DATA) == 0x105
    board.phy.set_physical_id(3)
    board.write_quadlet(PHY_CONTROL, 0)
    assert board.read_quadlet(PHY_DATA) >> 2 & 0x3F == 3
    board.write_quadlet(PHY_DATA, 0x1234)  # read-only
    assert board.read_quadlet(PHY_DATA) >> 2 & 0x3F == 3


def test_watchdog_period_register_is_16_bits(board: Snake2010Board) -> None:
    assert board.read_quadlet(WATCHDOG) == 0  # disabled by default
    board.write_quadlet(WATCHDOG, 0x12345)
    assert board.read_quadlet(WATCHDOG) == 0x2345


def test_version_register_is_read_only(board: Snake2010Board) -> None:
    version = board.read_quadlet(VERSION)
    board.write_quadlet(VERSION, version + 7)
    assert board.read_quadlet(VERSION) == version


def test_unmapped_addresses_read_zero_and_ignore_writes(board: Snake2010Board) -> None:
    for index in (5, 0xF, reg(1, 8), reg(1, 15), reg(8, 0), reg(15, 5), 0x100, 0xFFFF):
        board.write_quadlet(index, 0xFFFF_FFFF)
        assert board.read_quadlet(index) == 0
    ztheta = Snake2010Board(board_id=1, channels=4)
    assert ztheta.read_quadlet(reg(5, ADC)) == 0
    assert ztheta.read_quadlet(reg(4, DAC)) == 0x8000_8000


def test_only_the_low_16_offset_bits_are_decoded(board: Snake2010Board) -> None:
    assert board.read_quadlet(0xFFFF_0000_0000) == board.read_quadlet(STATUS)


# --- Table 1: channel registers ----------------------------------------------


def test_dac_quadlet_needs_valid_bit_and_sets_one_dac(board: Snake2010Board) -> None:
    assert board.read_quadlet(reg(2, DAC)) == 0x8000_8000  # both at mid-scale
    board.write_quadlet(reg(2, DAC), 0x1234)  # no valid bit: ignored
    assert board.read_quadlet(reg(2, DAC)) == 0x8000_8000
    board.write_quadlet(reg(2, DAC), VALID | 0x1234)
    assert board.read_quadlet(reg(2, DAC)) == 0x8000_1234
    board.write_quadlet(reg(2, DAC), VALID | CURRENT_LIMIT | 0x4321)
    assert board.read_quadlet(reg(2, DAC)) == 0x4321_1234


def test_dac_to_adc_loopback_section_8_1() -> None:
    # 16-bit DAC and 14-bit ADC over the same 0..2.5 V: the ADC sees the
    # top 14 bits of the DAC code, relative to 1.25 V.
    bench = Snake2010Board(board_id=0, wiring="loopback")
    for code in (0x0000, 0x0004, 0x7FFF, 0x8000, 0xA5A5, 0xFFFF):
        bench.write_quadlet(reg(4, DAC), VALID | code)
        bench.write_quadlet(reg(4, DAC), VALID | CURRENT_LIMIT | (0xFFFF - code))
        word = bench.read_quadlet(reg(4, ADC))
        assert pot_half(word) == (code >> 2) - 8192
        assert current_half(word) == ((0xFFFF - code) >> 2) - 8192
    bench.write_quadlet(reg(4, DAC), VALID | 0x0000)
    assert bench.read_quadlet(reg(4, ADC)) >> 16 == 0xE000  # -8192 sign-extended


def test_adc_reads_mid_scale_for_a_centred_idle_axis(board: Snake2010Board) -> None:
    # Pot at mid-travel (1.25 V) and no current: both halves read 0.
    assert board.read_quadlet(reg(1, ADC)) == 0


def test_pot_handshake_reads_and_writes_wiper_eeprom_outputs(board: Snake2010Board) -> None:
    control, data = reg(3, POT_CONTROL), reg(3, POT_DATA)
    board.write_quadlet(control, pot_frame(2, data=600))  # write wiper
    board.write_quadlet(control, pot_frame(1))  # read wiper
    answer = board.read_quadlet(data)
    assert answer & VALID
    assert answer >> 16 & 0xFF == 0x10  # echoes command 1, address 0
    assert answer & 0xFFFF == 600
    board.write_quadlet(control, pot_frame(4, 13, 0xBEEF))  # last EEPROM word
    board.write_quadlet(control, pot_frame(3, 13))
    assert board.read_quadlet(data) & 0xFFFF == 0xBEEF
    board.write_quadlet(control, pot_frame(6, data=0b10))  # O1 low, O2 high
    board.write_quadlet(control, pot_frame(5))
    assert board.read_quadlet(data) & 0xFFFF == 0b10
    assert board.read_quadlet(control) == pot_frame(5)


def test_pot_wiper_is_10_bits_and_eeprom_has_14_words(board: Snake2010Board) -> None:
    control, data = reg(1, POT_CONTROL), reg(1, POT_DATA)
    board.write_quadlet(control, pot_frame(2, data=0xFFFF))
    board.write_quadlet(control, pot_frame(1))
    assert board.read_quadlet(data) & 0xFFFF == 1023
    board.write_quadlet(control, pot_frame(3, 14))  # no 15th word
    assert not board.read_quadlet(data) & VALID


def test_encoder_preload_loads_the_count(board: Snake2010Board) -> None:
    board.write_quadlet(reg(5, PRELOAD), 0x80_0000)
    assert board.read_quadlet(reg(5, PRELOAD)) == 0x80_0000
    assert board.read_quadlet(reg(5, ENCODER)) == 0x80_0000  # no overflow flag


def test_encoder_counts_with_motion_and_flags_underflow(board: Snake2010Board) -> None:
    # Without a mid-point preload the counter starts at 0, so any reverse
    # motion drops below 0 and raises the overflow flag (bit 24).
    board.write_quadlet(reg(1, DAC), VALID | 0x6000)  # below mid-scale: reverse
    enable(board, 0b1)
    board.set_time(20 * MS)
    word = board.read_quadlet(reg(1, ENCODER))
    assert word & 1 << 24
    assert word & 0xFFFFFF > 0xF0_0000  # wrapped below zero
    board.write_quadlet(reg(1, PRELOAD), 0x80_0000)
    assert not board.read_quadlet(reg(1, ENCODER)) & 1 << 24
    board.set_time(40 * MS)
    assert encoder_count(board, 1) < 0x80_0000
    assert not board.read_quadlet(reg(1, ENCODER)) & 1 << 24


def test_encoder_flags_overflow_past_24_bits(board: Snake2010Board) -> None:
    board.write_quadlet(reg(2, PRELOAD), 0xFF_FFF0)
    board.write_quadlet(reg(2, DAC), VALID | 0xA000)
    enable(board, 0b10)
    board.set_time(20 * MS)
    word = board.read_quadlet(reg(2, ENCODER))
    assert word & 1 << 24
    assert word & 0xFFFFFF < 0x10_0000


def test_encoder_period_counts_768khz_clocks_per_edge(board: Snake2010Board) -> None:
    assert board.read_quadlet(reg(1, PERIOD)) == 0  # never moved
    for code, sign in ((0x8400, 1), (0x7C00, -1)):
        board.write_quadlet(reg(1, DAC), VALID | code)
        enable(board, 0b1)
        board.set_time(board.now + 300 * MS)  # settle
        before = encoder_count(board, 1)
        board.set_time(board.now + 10 * MS)
        edges_per_second = abs(encoder_count(board, 1) - before) * 100
        period = board.read_quadlet(reg(1, PERIOD))
        assert period >> 16 == 0
        signed = period - 0x10000 if period & 0x8000 else period
        assert signed * sign > 0
        assert abs(signed) == pytest.approx(768_000 / edges_per_second, rel=0.02)
    assert board.read_quadlet(reg(1, FREQUENCY)) == 0  # not implemented


# --- watchdog (section 6.3) ----------------------------------------------------


def test_watchdog_is_off_by_default(board: Snake2010Board) -> None:
    enable(board, 0x7F)
    board.set_time(2 * CLOCK_HZ)
    assert board.read_quadlet(STATUS) & 0xFF == 0x7F


def test_watchdog_fed_faster_than_its_period_never_fires(board: Snake2010Board) -> None:
    board.write_quadlet(WATCHDOG, 1000)  # 1000 x 5.2083 us = 5.2 ms
    enable(board, 0x7F)
    for _ in range(50):
        board.set_time(board.now + 5 * MS)  # < 5.2 ms between writes
        board.write_quadlet(reg(1, DAC), VALID | 0x8000)
    assert board.read_quadlet(STATUS) & 0xFF == 0x7F
    assert not board.read_quadlet(STATUS) & 1 << 23


def test_watchdog_timeout_uses_the_5_2_us_period_units(board: Snake2010Board) -> None:
    period = 1000
    board.set_time(1000 * WATCHDOG_UNIT + 100)  # a write between counter edges
    board.write_quadlet(WATCHDOG, period)
    enable(board, 0x7F)
    last_write = board.now
    # The free-running prescaler makes the first count come early, so the
    # timeout lands between (period - 1) and period units after the write.
    board.set_time(last_write + (period - 1) * WATCHDOG_UNIT)
    assert board.read_quadlet(STATUS) & 0xFF == 0x7F
    board.set_time(last_write + period * WATCHDOG_UNIT)
    status = board.read_quadlet(STATUS)
    assert status & 0xFF == 0
    assert status & 1 << 23
    assert board.leds == (False,) * 7


def test_watchdog_timeout_is_exact_on_counter_edges(board: Snake2010Board) -> None:
    board.write_quadlet(WATCHDOG, 3)  # written at tick 0, an edge
    enable(board, 0b1)
    board.set_time(3 * WATCHDOG_UNIT - 1)
    assert board.read_quadlet(STATUS) & 1
    board.set_time(3 * WATCHDOG_UNIT)
    assert not board.read_quadlet(STATUS) & 1


@pytest.mark.parametrize("phase", [0, 1, 128, 255])
@pytest.mark.parametrize("period", [1, 2, 37])
def test_watchdog_fires_on_the_prescaler_edge_after_period_counts(
    board: Snake2010Board, phase: int, period: int
) -> None:
    # Section 6.3: the counter steps on the edges of a free-running divide-by-256
    # prescaler and is cleared by the write, so a write at tick t times out at
    # (floor(t / 256) + P) * 256: not one tick earlier, whatever the write's phase.
    written = 40 * WATCHDOG_UNIT + phase
    board.set_time(written)
    board.write_quadlet(WATCHDOG, period)
    enable(board, 0b1)
    deadline = (written // WATCHDOG_UNIT + period) * WATCHDOG_UNIT
    board.set_time(deadline - 1)
    assert board.read_quadlet(STATUS) & 1, "fired before the prescaler edge"
    board.set_time(deadline)
    status = board.read_quadlet(STATUS)
    assert not status & 1 and status & 1 << 23, "did not fire on the prescaler edge"


def test_longest_watchdog_period_is_about_a_third_of_a_second(board: Snake2010Board) -> None:
    board.write_quadlet(WATCHDOG, 0xFFFF)
    enable(board, 0b1)
    board.set_time(int(0.340 * CLOCK_HZ))
    assert board.read_quadlet(STATUS) & 1
    board.set_time(int(0.342 * CLOCK_HZ))
    assert not board.read_quadlet(STATUS) & 1


def test_reads_do_not_feed_the_watchdog_but_block_writes_do(board: Snake2010Board) -> None:
    board.write_quadlet(WATCHDOG, 100)
    enable(board, 0b1)
    board.set_time(90 * WATCHDOG_UNIT)
    board.write_block(0, bytes(28))  # an all-invalid real-time block still feeds
    board.set_time(180 * WATCHDOG_UNIT)
    board.read_block(0, 128)
    board.read_quadlet(STATUS)
    assert board.read_quadlet(STATUS) & 1
    board.set_time(190 * WATCHDOG_UNIT)
    assert not board.read_quadlet(STATUS) & 1


def test_watchdog_flag_stays_until_amplifiers_are_enabled_again(
    board: Snake2010Board,
) -> None:
    board.write_quadlet(WATCHDOG, 10)
    enable(board, 0b11)
    board.set_time(20 * WATCHDOG_UNIT)
    board.write_quadlet(reg(1, DAC), VALID | 0x8000)
    assert board.read_quadlet(STATUS) & 1 << 23
    enable(board, 0b1)
    assert board.read_quadlet(STATUS) & (1 << 23 | 0xFF) == 0b1
    board.write_quadlet(WATCHDOG, 0)  # disabled again
    board.set_time(board.now + CLOCK_HZ)
    assert board.read_quadlet(STATUS) & 1


def test_watchdog_timeout_stops_the_motor(board: Snake2010Board) -> None:
    board.write_quadlet(WATCHDOG, 200)  # about 1 ms
    board.write_quadlet(reg(1, DAC), VALID | 0xA000)
    enable(board, 0b1)
    board.set_time(2 * MS)
    assert board.axis_state(1).current_amps == 0.0
    stopped_at = encoder_count(board, 1)
    board.set_time(3 * CLOCK_HZ)  # coasting against friction alone
    assert board.axis_state(1).velocity_rad_s < 1.0
    assert encoder_count(board, 1) >= stopped_at


# --- block transfers (section 6.4) ----------------------------------------------


def test_realtime_block_read_layout() -> None:
    bench = Snake2010Board(board_id=5, wiring="loopback")
    for channel in range(1, 8):
        bench.write_quadlet(reg(channel, DAC), VALID | channel * 0x1000)
        bench.write_quadlet(reg(channel, PRELOAD), 0x10_0000 * channel)
    enable(bench, 0b1000001)
    bench.set_time(12345)
    block = bench.read_block(0, 128)
    words = struct.unpack(">32I", block)
    assert words[0] == 12345  # clocks since power-up
    assert words[1] == bench.read_quadlet(STATUS) == 5 << 24 | 0b1000001
    assert words[2] == words[3] == 0
    for channel in range(1, 8):
        adc, encoder = words[3 + channel], words[10 + channel]
        assert pot_half(adc) == (channel * 0x1000 >> 2) - 8192
        assert encoder == 0x10_0000 * channel
        assert words[17 + channel] == bench.read_quadlet(reg(channel, PERIOD))
        assert words[24 + channel] == 0
    assert len(Snake2010Board(board_id=0, channels=4).read_block(0, 80)) == 80


def test_timestamp_counts_clocks_between_block_reads(board: Snake2010Board) -> None:
    board.read_block(0, 128)
    board.set_time(board.now + 49_152)  # 1 ms
    board.read_quadlet(STATUS)  # quadlet reads do not restart it
    assert struct.unpack(">I", board.read_block(0, 4))[0] == 49_152
    board.set_time(board.now + (1 << 32) + 7)
    assert struct.unpack(">I", board.read_block(0, 4))[0] == 7  # 32-bit wrap


def test_block_read_of_any_size(board: Snake2010Board) -> None:
    full = board.read_block(0, 128)
    assert board.read_block(0, 6)[4:] == full[4:6]
    longer = board.read_block(0, 136)
    assert longer[4:128] == full[4:128] and longer[128:] == bytes(8)
    assert board.read_block(0, 0) == b""
    with pytest.raises(DataError):
        board.read_block(0, 2052)  # beyond 512 quadlets


def test_block_read_elsewhere_reads_consecutive_registers(board: Snake2010Board) -> None:
    board.write_quadlet(reg(1, DAC), VALID | 0x9000)
    board.write_quadlet(reg(1, PRELOAD), 0x42)
    words = struct.unpack(">8I", board.read_block(reg(1, 0), 32))
    assert list(words) == [board.read_quadlet(reg(1, d)) for d in range(8)]
    assert words[DAC] & 0xFFFF == 0x9000 and words[PRELOAD] == 0x42


def test_realtime_block_write_layout_and_valid_bits(board: Snake2010Board) -> None:
    commands = [VALID | 0x1111, 0x2222, VALID | 0x3333, 0, 0, 0, VALID | CURRENT_LIMIT | 0x7777]
    board.write_block(0, struct.pack(">7I", *commands))
    dac = [board.read_quadlet(reg(c, DAC)) for c in range(1, 8)]
    assert dac[0] == 0x8000_1111
    assert dac[1] == 0x8000_8000  # no valid bit: untouched
    assert dac[2] == 0x8000_3333
    assert dac[6] == 0x7777_8000
    board.write_block(0, struct.pack(">I", VALID | 0x0042))  # short block: channel 1 only
    assert board.read_quadlet(reg(1, DAC)) == 0x8000_0042
    assert board.read_quadlet(reg(3, DAC)) == 0x8000_3333


def test_block_write_elsewhere_writes_consecutive_registers(board: Snake2010Board) -> None:
    board.write_block(reg(2, PRELOAD), struct.pack(">2I", 0x12_3456, 0xDEAD))
    assert board.read_quadlet(reg(2, PRELOAD)) == 0x12_3456
    assert board.read_quadlet(reg(2, ENCODER)) == 0x12_3456  # encoder data is read-only


def test_defect_stale_read_returns_previous_block() -> None:
    buggy = Snake2010Board(board_id=0, defects=frozenset({"stale-read"}))
    first = buggy.read_block(0, 128)
    enable(buggy, 0b1)
    buggy.set_time(MS)
    second = buggy.read_block(0, 128)
    assert second == first
    third = buggy.read_block(0, 128)
    assert struct.unpack(">2I", third[:8]) == (MS, 0b1)


# --- physics: commands move the motor, sensors follow ---------------------------


def test_motor_command_direction_moves_encoder_and_pot_together(board: Snake2010Board) -> None:
    board.write_quadlet(reg(1, PRELOAD), 0x80_0000)
    board.write_quadlet(reg(2, PRELOAD), 0x80_0000)
    board.write_quadlet(reg(1, DAC), VALID | 0x9000)
    board.write_quadlet(reg(2, DAC), VALID | 0x7000)
    enable(board, 0b111)
    board.set_time(200 * MS)
    assert encoder_count(board, 1) > 0x80_0000 and encoder_count(board, 2) < 0x80_0000
    assert pot_half(board.read_quadlet(reg(1, ADC))) > 0
    assert pot_half(board.read_quadlet(reg(2, ADC))) < 0
    assert encoder_count(board, 3) == 0  # mid-scale command: no motion
    assert board.read_quadlet(reg(3, ADC)) == 0


def test_disabled_amplifier_leaves_the_motor_still(board: Snake2010Board) -> None:
    board.write_quadlet(reg(1, DAC), VALID | 0xFFFF)
    board.set_time(100 * MS)
    assert encoder_count(board, 1) == 0


def test_current_reading_scales_with_equation_1_gain(board: Snake2010Board) -> None:
    # Torque mode (O1 low) cuts the current feedback, so the wiper changes
    # only the gain of the current signal that reaches the ADC.
    control = reg(1, POT_CONTROL)
    board.write_quadlet(control, pot_frame(6, data=0))
    board.write_quadlet(reg(1, DAC), VALID | CURRENT_LIMIT | 0x2000)
    board.write_quadlet(reg(1, DAC), VALID | 0xC000)
    enable(board, 0b1)
    readings = {}
    for wiper in (200, 600):
        board.write_quadlet(control, pot_frame(2, data=wiper))
        readings[wiper] = current_half(board.read_quadlet(reg(1, ADC)))

    def gain(w: int) -> float:
        return (12.1 + 10 * w / 1023) / (1.5 + 10 * (1023 - w) / 1023)

    assert readings[200] > 0
    assert readings[600] / readings[200] == pytest.approx(gain(600) / gain(200), rel=0.01)


def test_current_limit_dac_caps_the_motor_current(board: Snake2010Board) -> None:
    board.write_quadlet(reg(1, DAC), VALID | 0xF000)
    enable(board, 0b1)
    board.write_quadlet(reg(1, DAC), VALID | CURRENT_LIMIT | 0x4000)
    low = current_half(board.read_quadlet(reg(1, ADC)))
    board.write_quadlet(reg(1, DAC), VALID | CURRENT_LIMIT | 0x8000)
    high = current_half(board.read_quadlet(reg(1, ADC)))
    assert high == pytest.approx(2 * low, rel=0.01)


def test_speed_mode_holds_speed_better_than_torque_mode() -> None:
    speeds = {}
    for outputs in (0b01, 0b00):  # O1 high = speed control, low = torque
        node = Snake2010Board(board_id=0)
        node.write_quadlet(reg(1, POT_CONTROL), pot_frame(6, data=outputs))
        node.write_quadlet(reg(1, DAC), VALID | 0x9000)
        enable(node, 0b1)
        node.set_time(30 * MS)
        speeds[outputs] = encoder_count(node, 1)
    assert speeds[0b01] > speeds[0b00]


def test_motion_does_not_depend_on_how_often_time_is_set() -> None:
    coarse, fine = Snake2010Board(board_id=0), Snake2010Board(board_id=0)
    for node in (coarse, fine):
        node.write_quadlet(reg(1, DAC), VALID | 0x9800)
        enable(node, 0b1)
    coarse.set_time(100 * MS)
    for tick in range(0, 100 * MS + 1, 7919):
        fine.set_time(tick)
    fine.set_time(100 * MS)
    assert abs(encoder_count(coarse, 1) - encoder_count(fine, 1)) <= 1


def test_time_cannot_go_backwards(board: Snake2010Board) -> None:
    board.set_time(10)
    with pytest.raises(ValueError):
        board.set_time(9)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 0x1FF), st.integers(0, 0xFFFF_FFFF), st.integers(0, MS)),
        max_size=40,
    )
)
def test_any_register_writes_keep_the_board_consistent(
    writes: list[tuple[int, int, int]],
) -> None:
    node = Snake2010Board(board_id=9)
    for index, value, delay in writes:
        node.set_time(node.now + delay)
        node.write_quadlet(index, value)
        status = node.read_quadlet(STATUS)
        assert status >> 24 == 9  # the rotary switch never changes
        assert status >> 8 & 0xFF == 0
        assert node.leds == tuple(bool(status >> n & 1) for n in range(7))
        encoder = node.read_quadlet(reg(1, ENCODER))
        assert encoder >> 25 == 0
