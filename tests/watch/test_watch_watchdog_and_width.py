"""The live view tells the amplifiers' real state and fits the terminal it has.

A snake2010 emulator behind a LocalPort and a manual clock: the README's
watchdog (period 0x0f00 = 3840 counts of 192 kHz = 20 ms) fed at a 10 Hz
refresh trips between feeds (docs/boards/snake2010.md), and the board's own
status then says so; the view must not claim the amplifier is on.
"""

from __future__ import annotations

import pytest

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.spec import REG_WATCHDOG_PERIOD
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host import LocalPort, ManualClock
from fw1394.watch.controls import Action, Command, Controller
from fw1394.watch.conversions import Conversions
from fw1394.watch.live import live_render
from fw1394.watch.sampler import WatchedBoard
from fw1394.watch.view import COLUMNS, TABLE_HEADER, BoardPanel, view_lines

README_WATCHDOG = 0x0F00  # 20 ms


def controller_with_watchdog(period: int) -> tuple[Controller, ManualClock]:
    clock = ManualClock()
    board = Snake2010Board(board_id=0)
    port = LocalPort({0: board}, clock)
    port.write_quadlet(0, REG_WATCHDOG_PERIOD, period)
    controller = Controller([WatchedBoard(port, 0, "snake2010", 7)])
    controller.refresh()
    assert controller.handle(Command(Action.ENABLE))  # channel 1's amplifier
    return controller, clock


def refresh_after(controller: Controller, clock: ManualClock, seconds: float) -> None:
    clock.advance(round(seconds * TICKS_PER_SECOND))
    controller.refresh()


def test_a_watchdog_shorter_than_the_refresh_trips_and_the_view_says_so() -> None:
    controller, clock = controller_with_watchdog(README_WATCHDOG)
    refresh_after(controller, clock, 0.1)  # 10 Hz: 100 ms between feeds
    reading = controller.boards[0].reading
    assert reading is not None
    assert reading.status.watchdog_timeout and not reading.channels[0].enabled
    lines = [
        line.text for line in live_render("arm", Conversions.of(), 10.0)(controller, 10.0, None)
    ]
    assert not any("amplifier(s) on, feeding" in line for line in lines)
    notice = lines[1]
    assert notice.startswith("watchdog TIMEOUT on node 0: 0 of 1 amplifier(s) enabled here on")
    assert "20.00 ms watchdog is shorter than the 100 ms between feeds" in notice


def test_a_watchdog_fed_often_enough_keeps_the_amplifier_on() -> None:
    controller, clock = controller_with_watchdog(README_WATCHDOG)
    for _ in range(5):
        refresh_after(controller, clock, 0.019)  # fed every 19 ms: within 20 ms
    reading = controller.boards[0].reading
    assert reading is not None and reading.channels[0].enabled
    assert not reading.status.watchdog_timeout
    lines = [
        line.text for line in live_render("arm", Conversions.of(), 50.0)(controller, 50.0, None)
    ]
    assert (
        lines[1] == "holding 1 of 1 amplifier(s) enabled here on, feeding the watchdog every 20 ms"
    )


@pytest.mark.parametrize("width", [80, 64])
def test_the_view_fits_the_width_and_names_what_it_hid(width: int) -> None:
    controller, clock = controller_with_watchdog(README_WATCHDOG)
    refresh_after(controller, clock, 0.1)
    render = live_render("a-rather-long-bus-name", Conversions.of(), 10.0)
    full = [line.text for line in render(controller, 10.0, None)]
    narrow = [line.text for line in render(controller, 10.0, width)]
    assert max(len(line) for line in full) > width  # there is something to fit
    assert all(len(line) <= width for line in narrow)
    hidden = next(line for line in narrow if line.startswith("columns hidden to fit"))
    header = next(line for line in narrow if line.lstrip().startswith("ch "))
    for name, _ in COLUMNS:
        assert (name.strip() in header.split()) != (name.strip() in hidden.split(": ")[1].split())
    # Nothing is cut: table rows keep every cell of the columns shown, in order, and
    # every word of the other lines is still there (wrapped).
    shown = [i for i, (name, _) in enumerate(COLUMNS) if name.strip() in header.split()]
    start, thin_start = full.index(TABLE_HEADER), narrow.index(header)
    full_rows = full[start : start + 8]  # the header and seven channels
    narrow_rows = narrow[thin_start : thin_start + 8]
    for wide, thin in zip(full_rows, narrow_rows, strict=True):
        assert thin[1:].split() == [wide[1:].split()[i] for i in shown]
    words = " ".join(narrow).split()
    for line in full:
        if line not in full_rows:
            assert all(word in words for word in line.split()), line


def test_an_unlimited_width_keeps_the_full_table() -> None:
    controller, _ = controller_with_watchdog(0)
    reading = controller.boards[0].reading
    assert reading is not None
    lines = [
        line.text
        for line in view_lines("t", [BoardPanel(0, "snake2010", reading)], Conversions.of())
    ]
    assert TABLE_HEADER in lines
    assert not any(line.startswith("columns hidden") for line in lines)
