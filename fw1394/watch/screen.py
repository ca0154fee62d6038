"""The live view: a curses loop that refreshes the boards and reads keys.

The loop only draws lines made by a render function and hands keys to the
:class:`~fw1394.watch.controls.Controller`; it talks to the terminal through
the small :class:`Screen` protocol, which a curses window satisfies and a
test can fake.
"""

from __future__ import annotations

import contextlib
import curses
import time
from collections.abc import Callable, Mapping
from typing import Protocol

from fw1394.watch.controls import Controller, command_for_key
from fw1394.watch.view import Line, Style

Render = Callable[[Controller, float, int | None], list[Line]]
"""Lines of the screen for a controller, the refresh rate achieved (Hz) and the width."""


class Screen(Protocol):
    def getch(self) -> int: ...
    def timeout(self, delay: int, /) -> None: ...
    def getmaxyx(self) -> tuple[int, int]: ...
    def erase(self) -> None: ...
    def addnstr(self, y: int, x: int, text: str, n: int, attr: int, /) -> None: ...
    def refresh(self) -> None: ...


def run_loop(
    screen: Screen,
    controller: Controller,
    render: Render,
    rate_hz: float,
    styles: Mapping[Style, int] | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> None:
    """Refresh at ``rate_hz`` and act on keys until the quit key."""
    period = 1.0 / rate_hz
    attributes = styles or {}
    controller.refresh()
    last = clock()
    achieved = 0.0
    while True:
        draw(screen, render(controller, achieved, screen.getmaxyx()[1] - 1), attributes)
        screen.timeout(max(0, round((last + period - clock()) * 1000)))
        key = screen.getch()
        if key != -1:
            command = command_for_key(key)
            if command is not None and not controller.handle(command):
                return
        now = clock()
        if now - last >= period:
            controller.refresh()
            achieved = 1.0 / (now - last)
            last = now


def draw(screen: Screen, lines: list[Line], attributes: Mapping[Style, int]) -> None:
    height, width = screen.getmaxyx()
    screen.erase()
    for row, line in enumerate(lines[:height]):
        # A terminal that shrank between getmaxyx and the write: the next frame fits.
        with contextlib.suppress(curses.error):
            screen.addnstr(row, 0, line.text, width - 1, attributes.get(line.style, 0))
    screen.refresh()


def curses_styles() -> dict[Style, int]:
    """Attributes per style; colours only where the terminal has them."""
    alert = curses.A_BOLD
    if curses.has_colors():
        curses.start_color()
        curses.use_default_colors()
        curses.init_pair(1, curses.COLOR_RED, -1)
        alert |= curses.color_pair(1)
    return {
        Style.TITLE: curses.A_BOLD,
        Style.HEADER: curses.A_BOLD,
        Style.SELECTED: curses.A_REVERSE,
        Style.ALERT: alert,
        Style.DIM: curses.A_DIM,
    }


def run_curses(controller: Controller, render: Render, rate_hz: float) -> None:
    """Take over the terminal for :func:`run_loop` and give it back however the loop ends."""

    def main(window: curses.window) -> None:
        with contextlib.suppress(curses.error):  # terminals that cannot hide the cursor
            curses.curs_set(0)
        run_loop(window, controller, render, rate_hz, curses_styles())

    curses.wrapper(main)
