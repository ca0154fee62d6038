"""``fw1394 watch`` keys and commands, and the live loop driven without a terminal.

Boards run in-process behind a :class:`LocalPort`; the loop runs against a
fake screen that replays keys and advances a manual clock, so the tests see
exactly which transactions each key causes and what is left when it quits.
"""

from __future__ import annotations

import curses
from collections import deque
from collections.abc import Callable, Mapping

import pytest

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.spec import REG_STATUS, REG_WATCHDOG_PERIOD
from fw1394.engine.space import TICKS_PER_SECOND, AddressSpace
from fw1394.host import Board, LocalPort, ManualClock
from fw1394.watch.controls import Action, Command, Controller, command_for_key
from fw1394.watch.conversions import Conversions
from fw1394.watch.live import live_render
from fw1394.watch.sampler import WatchedBoard
from fw1394.watch.screen import run_loop

MIDPOINT = 0x8000


class CountingPort(LocalPort):
    """LocalPort that counts write transactions (each one feeds a watchdog)."""

    def __init__(self, nodes: Mapping[int, AddressSpace], clock: Callable[[], int]) -> None:
        super().__init__(nodes, clock)
        self.writes = 0

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self.writes += 1
        super().write_quadlet(node, offset, value)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self.writes += 1
        super().write_block(node, offset, data)


class Robot:
    """A 7-channel and a 4-channel board, as the snake robot has, and a controller."""

    def __init__(self, read_only: bool = False) -> None:
        self.clock = ManualClock()
        self.arm = Snake2010Board(board_id=0)
        self.stage = Snake2010Board(board_id=1, channels=4)
        self.port = CountingPort({0: self.arm, 1: self.stage}, self.clock)
        self.boards = [
            WatchedBoard(self.port, 0, "snake2010", 7),
            WatchedBoard(self.port, 1, "snake2010-ztheta", 4),
        ]
        self.controller = Controller(self.boards, dac_step=1000, read_only=read_only)

    def press(self, *keys: int | str) -> None:
        for key in keys:
            code = ord(key) if isinstance(key, str) else key
            command = command_for_key(code)
            assert command is not None, f"no command for {key!r}"
            assert self.controller.handle(command)

    def dac(self, board: Snake2010Board, channel: int) -> int:
        return board.channels[channel - 1].motor_command


@pytest.fixture
def robot() -> Robot:
    return Robot()


def test_keys_map_to_commands() -> None:
    assert command_for_key(ord("q")) == Command(Action.QUIT)
    assert command_for_key(ord("e")) == Command(Action.ENABLE)
    assert command_for_key(ord("D")) == Command(Action.DISABLE_ALL)
    assert command_for_key(ord("+")) == Command(Action.DAC_UP)
    assert command_for_key(ord("0")) == Command(Action.DAC_ZERO)
    assert command_for_key(ord("3")) == Command(Action.CHANNEL, 3)
    assert command_for_key(curses.KEY_UP) == Command(Action.PREVIOUS_AXIS)
    assert command_for_key(ord("\t")) == Command(Action.NEXT_BOARD)
    assert command_for_key(curses.KEY_RESIZE) is None
    assert command_for_key(ord("x")) is None


def test_quit_ends_the_view(robot: Robot) -> None:
    assert not robot.controller.handle(Command(Action.QUIT))


def test_selection_runs_through_both_boards(robot: Robot) -> None:
    controller = robot.controller
    robot.press(curses.KEY_UP)  # from the first row up: the last row of the last board
    assert controller.selected == (1, 3)
    robot.press(curses.KEY_DOWN)
    assert controller.selected == (0, 0)
    robot.press("7", curses.KEY_DOWN)
    assert controller.selected == (1, 0)
    robot.press(curses.KEY_LEFT, "6", "\t")  # the stage has only 4 channels
    assert controller.selected == (1, 3)
    robot.press("9")
    assert controller.selected == (1, 3)
    assert controller.message == "node 1 has no channel 9"


def test_enable_and_disable_the_selected_amplifier(robot: Robot) -> None:
    robot.controller.refresh()
    robot.press("3", "e")
    assert robot.arm.status & 0xFF == 0b100
    assert robot.controller.enabled_here == {(0, 2)}
    assert robot.controller.message == "node 0 ch 3: amplifier on"
    robot.press("d")
    assert robot.arm.status & 0xFF == 0
    assert robot.controller.enabled_here == set()


def test_enable_and_disable_all(robot: Robot) -> None:
    robot.press("E")
    assert robot.arm.status & 0xFF == 0x7F and robot.stage.status & 0xFF == 0x0F
    assert all(robot.arm.leds) and all(robot.stage.leds)
    robot.press("D")
    assert robot.arm.status & 0xFF == 0 and robot.stage.status & 0xFF == 0


def test_motor_command_steps_from_the_board_s_value(robot: Robot) -> None:
    robot.controller.refresh()
    robot.press(curses.KEY_RIGHT, "2", "+", "+")
    assert robot.dac(robot.stage, 2) == MIDPOINT + 2000
    assert robot.controller.message == "node 1 ch 2: motor command 0x87d0 (+2000)"
    # The view shows the new command at once (read back from the DAC register).
    reading = robot.boards[1].reading
    assert reading is not None and reading.channels[1].dac == MIDPOINT + 2000
    robot.press("-", "-", "-")
    assert robot.dac(robot.stage, 2) == MIDPOINT - 1000
    robot.press("0")
    assert robot.dac(robot.stage, 2) == MIDPOINT
    assert robot.controller.commanded_here == set()
    robot.controller.dac_step = 0x8000
    robot.press("+", "+")
    assert robot.dac(robot.stage, 2) == 0xFFFF  # clipped at the top of the DAC


def test_read_only_view_sends_nothing() -> None:
    robot = Robot(read_only=True)
    robot.controller.refresh()
    before = robot.port.writes
    robot.press("e", "E", "+", "0", "r", curses.KEY_DOWN)
    assert robot.port.writes == 0 == before
    assert robot.arm.status & 0xFF == 0
    assert robot.controller.selected == (0, 1)  # selection still moves
    assert robot.controller.message.startswith("read-only view")


def test_quitting_undoes_only_what_the_view_did(robot: Robot) -> None:
    # Another host has channel 5 on and commanded; it must stay so.
    other = Board(robot.port, 0)
    other.set_power_control(other.power_word([4], True))
    other.set_motor_voltage(4, MIDPOINT + 500)
    other.apply_all_outputs()
    robot.press("1", "e", "2", "+")  # "+" refreshes node 0: the view knows ch 5 is on
    robot.press(curses.KEY_RIGHT, "E")
    assert robot.arm.status & 0xFF == 0x7F and robot.stage.status & 0xFF == 0x0F
    report, safe = robot.controller.shutdown()
    assert safe
    assert report == [
        "node 0: motor command 2 stopped; amplifier 1,2,3,4,6,7 off",
        "node 1: amplifier 1,2,3,4 off",
    ]
    assert robot.arm.status & 0xFF == 0b1_0000
    assert robot.dac(robot.arm, 2) == MIDPOINT and robot.dac(robot.arm, 5) == MIDPOINT + 500
    assert robot.stage.status & 0xFF == 0
    assert robot.controller.shutdown() == ([], True)  # nothing left to undo


def test_watchdog_is_fed_only_while_the_view_holds_amplifiers(robot: Robot) -> None:
    for node in (0, 1):
        robot.port.write_quadlet(node, REG_WATCHDOG_PERIOD, 3840)  # 20 ms
    controller = robot.controller
    before = robot.port.writes
    for _ in range(5):
        robot.clock.advance_seconds(0.010)
        controller.refresh()
    assert robot.port.writes == before  # watching alone never feeds a watchdog
    robot.press("e")
    for _ in range(20):
        robot.clock.advance_seconds(0.010)
        controller.refresh()
    reading = robot.boards[0].reading
    assert reading is not None and not reading.status.watchdog_timeout
    assert reading.channels[0].enabled
    # The stage holds nothing of ours: nobody fed it, and its watchdog did fire
    # when the view wrote nothing to it (its flag is set only by a timeout).
    robot.stage.write_quadlet(REG_STATUS, 0x0101)
    robot.clock.advance_seconds(0.1)
    controller.refresh()
    stage = robot.boards[1].reading
    assert stage is not None and stage.status.watchdog_timeout


def test_failures_become_messages_not_crashes() -> None:
    clock = ManualClock()
    port = LocalPort({}, clock)  # node 0 is gone
    board = WatchedBoard(port, 0, "snake2010", 7)
    controller = Controller([board])
    controller.refresh()
    assert board.reading is None and board.problem == "refresh failed: no node 0 on this port"
    assert controller.handle(Command(Action.ENABLE))
    assert controller.message == "node 0: enable failed: no node 0 on this port"
    assert controller.enabled_here == set()


class FakeScreen:
    """Replays keys (None: no key before the timeout) on a clock it moves itself."""

    def __init__(self, keys: list[int | None], clock: ManualClock) -> None:
        self.keys = deque(keys)
        self.clock = clock
        self.seconds = 0.0
        self.delay = 0
        self.delays: list[int] = []
        self.rows: dict[int, str] = {}
        self.frames: list[list[str]] = []

    def now(self) -> float:
        return self.seconds

    def getch(self) -> int:
        key = self.keys.popleft() if self.keys else ord("q")
        if key is None:
            # No key: the timeout runs out, as curses would wait for it.
            self.seconds += self.delay / 1000
            self.clock.advance(round(self.delay / 1000 * TICKS_PER_SECOND))
            return -1
        return key

    def timeout(self, delay: int, /) -> None:
        self.delay = delay
        self.delays.append(delay)

    def getmaxyx(self) -> tuple[int, int]:
        return 30, 120

    def erase(self) -> None:
        self.rows = {}

    def addnstr(self, y: int, x: int, text: str, n: int, attr: int, /) -> None:
        self.rows[y] = text[:n]

    def refresh(self) -> None:
        self.frames.append([self.rows[y] for y in sorted(self.rows)])


def test_live_loop_keys_refresh_and_quit(robot: Robot) -> None:
    robot.boards[0].read_pot_settings()
    screen = FakeScreen([None, ord("e"), None, ord("+"), None, None, ord("q")], robot.clock)
    render = live_render("test", Conversions.of())
    run_loop(screen, robot.controller, render, rate_hz=10, clock=screen.now)
    # It waits for keys until the next refresh is due, 100 ms after the last one.
    assert max(screen.delays) == 100 and min(screen.delays) >= 0
    last = screen.frames[-1]
    assert last[0] == "fw1394 watch  bus test  2 board(s)  10.0 Hz"
    # The board reports the amplifier on: the watchdog (off here) did not trip.
    assert last[1].startswith("holding 1 of 1 amplifier(s) enabled here on, feeding the watchdog")
    assert any(line.startswith("> 1  ON   -   *") for line in last)
    assert "node 0 ch 1: motor command 0x83e8 (+1000)" in last
    assert last[-1].startswith("keys:")
    assert "dt 4915200 clk (100.000 ms)" in last[3]  # refreshed every 100 ms of board time
    assert robot.arm.status & 0xFF == 1
    assert robot.arm.axis_state(1).velocity_rad_s > 0  # the motor was running
    assert robot.controller.shutdown()[1]
    assert robot.arm.status & 0xFF == 0 and robot.dac(robot.arm, 1) == MIDPOINT
