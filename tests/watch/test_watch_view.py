"""``fw1394 watch`` view model: from latched board data to text and JSON, no terminal.

Boards run in-process behind a :class:`LocalPort`; every expectation comes
from the board's documented behaviour (docs/boards/snake2010.md): the status
word of Table 2, loopback wiring reading a DAC code d back as ``d >> 2``,
about 9.9 encoder counts/s per DAC code in speed mode, the 192 kHz watchdog.
"""

from __future__ import annotations

import json

import pytest

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.spec import REG_WATCHDOG_PERIOD
from fw1394.host import LocalPort, ManualClock
from fw1394.watch.conversions import (
    Conversions,
    adc_volts,
    counts_per_second,
    dac_volts,
    watchdog_seconds,
)
from fw1394.watch.detect import kind_from_argv, snake_channels
from fw1394.watch.readings import BoardReading, decode_status
from fw1394.watch.sampler import WatchedBoard
from fw1394.watch.view import (
    TABLE_HEADER,
    BoardPanel,
    Style,
    channel_dict,
    reading_dict,
    view_lines,
)

MIDPOINT = 0x8000
CONVERSIONS = Conversions.of()


def watched(
    emulator: Snake2010Board, clock: ManualClock, kind: str = "snake2010", node: int = 0
) -> WatchedBoard:
    return WatchedBoard(LocalPort({node: emulator}, clock), node, kind, len(emulator.channels))


def texts(reading: BoardReading, selected: tuple[int, int] | None = None) -> list[str]:
    panel = BoardPanel(reading.node, reading.kind, reading)
    return [line.text for line in view_lines("title", [panel], CONVERSIONS, selected)]


def row(lines: list[str], channel: int) -> list[str]:
    """The cells of channel ``channel``'s table row."""
    header = lines.index(TABLE_HEADER)
    return lines[header + channel].split()


# --- status word (Table 2) ------------------------------------------------------


def test_status_word_is_split_into_its_fields() -> None:
    # board 5, watchdog timeout, fault on channel 2, channels 1 and 2 enabled.
    status = decode_status(0x0582_0003, channels=7)
    assert status.board_id == 5
    assert status.watchdog_timeout
    assert status.faults == (False, True, False, False, False, False, False)
    assert status.enables == (True, True, False, False, False, False, False)
    # A faulted amplifier keeps its enable bit but its LED goes dark.
    assert status.leds == (True, False, False, False, False, False, False)


def test_status_bits_of_missing_channels_are_dropped() -> None:
    status = decode_status(0x00FF, channels=4)
    assert status.enables == (True,) * 4


# --- conversions ------------------------------------------------------------------


def test_converter_scales() -> None:
    assert adc_volts(8192) == 1.25 and adc_volts(0) == 0.0
    assert dac_volts(MIDPOINT) == 1.25
    assert counts_per_second(768) == 1000.0  # 768 kHz clock, 768 clocks per edge
    assert counts_per_second(-768) == -1000.0
    assert counts_per_second(0x7FFF) == 0.0 and counts_per_second(0) == 0.0
    assert watchdog_seconds(0xFFFF) == pytest.approx(0.3413, abs=1e-4)
    assert CONVERSIONS.motor_volts(MIDPOINT) == 0.0
    assert CONVERSIONS.motor_volts(0xFFFF) == pytest.approx(10.0, abs=1e-3)  # bridge gain 8
    assert CONVERSIONS.pot_mm(8192) == 10.0  # mid-travel of 20 mm
    assert CONVERSIONS.limit_amps(MIDPOINT) == 0.5


# --- a fresh board -------------------------------------------------------------------


def test_fresh_board_snapshot() -> None:
    clock = ManualClock()
    board = watched(Snake2010Board(board_id=3), clock)
    board.read_pot_settings()
    clock.advance_seconds(0.1)
    lines = texts(board.sample())
    assert lines[0] == "title"
    assert lines[2].startswith("node 0  snake2010  board id 3  status 0x03000000  dt 4915200 clk")
    assert "watchdog off (period 0), no timeout  enabled none  faults none  LEDs none" in lines[3]
    for channel in range(1, 8):
        # Power-up state: disabled, counter at 0, pot and current at 1.25 V,
        # both DACs at mid-scale, wiper 375 in speed mode (gain 2.01).
        cells = row(lines, channel)
        assert cells[:4] == [str(channel), "off", "-", "."]
        assert cells[4:] == [
            "-8388608", "+0", "+0.0", "8192", "10.00", "8192", "+0.0",
            "0x8000", "+0.00", "500", "spd", "2.01",
        ]  # fmt: skip
    assert len(lines) == 4 + 7 + 1


def test_table_rows_line_up_with_the_header() -> None:
    clock = ManualClock()
    emulator = Snake2010Board(board_id=0)
    board = watched(emulator, clock)
    board.board.set_encoder_preload(0, 0x80_0000)
    board.board.set_power_control(board.board.power_word([0], True))
    board.board.set_motor_voltage(0, 0xF000)
    board.board.apply_all_outputs()
    clock.advance_seconds(0.05)
    lines = texts(board.sample())
    header = lines.index(TABLE_HEADER)
    for line in lines[header + 1 : header + 8]:
        assert len(line) == len(TABLE_HEADER)


# --- a moving motor ----------------------------------------------------------------


def test_enabled_motor_shows_motion_current_and_command() -> None:
    clock = ManualClock()
    emulator = Snake2010Board(board_id=1)
    board = watched(emulator, clock)
    board.read_pot_settings()
    host = board.board
    host.set_encoder_preload(0, 0x80_0000)
    host.set_power_control(host.power_word([0], True))
    host.set_motor_voltage(0, MIDPOINT + 3000)
    host.apply_all_outputs()
    clock.advance_seconds(0.3)
    reading = board.sample()
    channel = reading.channels[0]
    assert channel.enabled and channel.led and not channel.fault
    assert channel.dac == MIDPOINT + 3000
    # Speed mode at wiper 375: about 9.9 counts/s per DAC code.
    speed = counts_per_second(channel.period)
    assert speed == pytest.approx(9.9 * 3000, rel=0.1)
    assert channel.encoder > 0x80_0000
    facts = channel_dict(channel, CONVERSIONS)
    assert facts["current_amps"] > 0 and facts["motor_volts"] == pytest.approx(0.916, abs=1e-3)
    assert facts["pot_mm"] > 10.0  # moved forward from mid-travel
    state = emulator.axis_state(1)
    assert facts["pot_mm"] == pytest.approx(state.position_mm, abs=0.01)
    assert facts["current_amps"] == pytest.approx(state.current_amps, abs=0.002)
    cells = row(texts(reading), 1)
    assert cells[1:4] == ["ON", "-", "*"]
    assert cells[11] == f"{MIDPOINT + 3000:#06x}" and cells[12] == "+0.92"


def test_loopback_wiring_reads_the_dac_back_on_the_pot_input() -> None:
    clock = ManualClock()
    board = watched(Snake2010Board(board_id=0, wiring="loopback"), clock)
    board.board.set_motor_voltage(2, 0x9000)
    board.board.apply_all_outputs()
    channel = board.sample().channels[2]
    assert channel.pot == 0x9000 >> 2 and channel.dac == 0x9000


# --- alerts: faults, watchdog, overflow --------------------------------------------


def test_fault_watchdog_timeout_and_overflow_are_alerts() -> None:
    clock = ManualClock()
    emulator = Snake2010Board(board_id=2)
    board = watched(emulator, clock)
    host = board.board
    board.port.write_quadlet(0, REG_WATCHDOG_PERIOD, 192)  # 1 ms
    host.set_encoder_preload(1, 0)  # at the bottom: any reverse motion overflows
    host.set_power_control(host.power_word([0, 1, 2], True))
    host.set_motor_voltage(1, MIDPOINT - 4000)
    host.apply_all_outputs()
    emulator.set_amplifier_fault(3, True)
    clock.advance_seconds(0.5)  # no writes: the watchdog fires after 1 ms
    reading = board.sample()
    assert reading.status.watchdog_timeout and reading.watchdog_period == 192
    panel = BoardPanel(0, "snake2010", reading)
    lines = view_lines("title", [panel], CONVERSIONS)
    watchdog = lines[3]
    assert watchdog.style is Style.ALERT
    assert "watchdog 1.00 ms (period 192), TIMEOUT" in watchdog.text
    assert "enabled none  faults 3" in watchdog.text  # the timeout switched all off
    header = [line.text for line in lines].index(TABLE_HEADER)
    overflowed, faulted = lines[header + 2], lines[header + 3]
    assert overflowed.style is Style.ALERT and "!" in overflowed.text.split()[4]
    assert faulted.style is Style.ALERT and faulted.text.split()[2] == "FLT"
    assert lines[header + 1].style is Style.NORMAL


def test_selected_row_is_marked() -> None:
    clock = ManualClock()
    board = watched(Snake2010Board(board_id=0), clock)
    panel = BoardPanel(0, "snake2010", board.sample())
    lines = view_lines("t", [panel, panel], CONVERSIONS, selected=(1, 2))
    marked = [line for line in lines if line.text.startswith(">")]
    assert len(marked) == 1 and marked[0].style is Style.SELECTED
    assert lines.index(marked[0]) > len(lines) // 2  # in the second panel
    assert marked[0].text.split()[1] == "3"


def test_without_pot_settings_gain_dependent_columns_are_unknown() -> None:
    clock = ManualClock()
    board = watched(Snake2010Board(board_id=0), clock)
    reading = board.sample()  # read-only: the pot handshake was not run
    assert row(texts(reading), 1)[10:] == ["?", "0x8000", "+0.00", "500", "?", "?"]
    facts = channel_dict(reading.channels[0], CONVERSIONS)
    assert facts["current_amps"] is None and facts["wiper"] is None


def test_board_without_reading_and_with_a_problem() -> None:
    panel = BoardPanel(4, "snake2010", None, "refresh failed: no node 4 on this port")
    lines = view_lines("t", [panel], CONVERSIONS)
    assert lines[2].text == "node 4  snake2010  (no reading yet)"
    assert lines[3].style is Style.ALERT and "no node 4" in lines[3].text


def test_z_theta_board_has_four_rows_and_json() -> None:
    clock = ManualClock()
    board = watched(Snake2010Board(board_id=9, channels=4), clock, "snake2010-ztheta", node=1)
    board.read_pot_settings()
    reading = board.sample()
    lines = texts(reading)
    assert lines[-1].split()[0] == "4"
    facts = json.loads(json.dumps(reading_dict(reading, CONVERSIONS)))
    assert facts["node"] == 1 and facts["board_id"] == 9 and facts["kind"] == "snake2010-ztheta"
    assert [c["channel"] for c in facts["channels"]] == [1, 2, 3, 4]
    assert facts["channels"][0]["wiper"] == 375 and facts["channels"][0]["speed_mode"] is True


# --- board kind detection -------------------------------------------------------------


def test_board_kind_from_a_node_command_line() -> None:
    python = ["/usr/bin/python3", "-m", "fw1394.cli.bus", "node", "run", "--name", "b"]
    assert kind_from_argv([*python, "--board", "snake2010-ztheta", "--board-id", "1"]) == (
        "snake2010-ztheta"
    )
    assert kind_from_argv([*python, "--board=qla1"]) == "qla1"
    assert kind_from_argv([*python, "--board-id", "2"]) == "memory"  # node run's default
    assert kind_from_argv(["/usr/bin/python3", "server.py"]) is None
    entry = ["/usr/bin/python3", "-m", "fw1394.node", "--name", "b"]
    assert kind_from_argv([*entry, "--board", "qla1"]) == "qla1"
    assert kind_from_argv(entry) == "memory"


def test_channel_count_of_board_kinds() -> None:
    assert snake_channels("snake2010") == 7
    assert snake_channels("snake2010-ztheta") == 4
    assert snake_channels("memory") is None
    assert snake_channels("qla1") is None
    assert snake_channels("no-such-board") is None
