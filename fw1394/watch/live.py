"""Putting the live view together: its frame, and leaving the boards safe however it ends."""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from fw1394.watch.controls import KEY_HELP, Controller
from fw1394.watch.conversions import Conversions
from fw1394.watch.screen import Render, run_curses
from fw1394.watch.view import BoardPanel, Line, Style, view_lines


def panels(controller: Controller) -> list[BoardPanel]:
    return [BoardPanel(w.node, w.kind, w.reading, w.problem) for w in controller.boards]


def live_render(bus: str, conversions: Conversions) -> Render:
    """The frame of the live view of bus ``bus``."""

    def render(controller: Controller, rate_hz: float) -> list[Line]:
        title = f"fw1394 watch  bus {bus}  {len(controller.boards)} board(s)  {rate_hz:4.1f} Hz"
        if controller.read_only:
            title += "  read-only"
        held = len(controller.enabled_here)
        if held:
            title += f"  holding {held} amplifier(s) on, feeding the watchdog"
        footer = [Line(controller.message), Line(KEY_HELP, Style.DIM)]
        return view_lines(title, panels(controller), conversions, controller.selected, footer)

    return render


class Stopped(Exception):
    """The process was asked to end (SIGTERM, SIGHUP): leave as after the quit key."""


@contextmanager
def stop_on_signals() -> Iterator[None]:
    """Turn SIGTERM and SIGHUP into :class:`Stopped` for the duration."""

    def stop(signum: int, frame: FrameType | None) -> None:
        raise Stopped(signal.Signals(signum).name)

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGTERM, signal.SIGHUP)}
    try:
        yield
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)


def run_live(controller: Controller, render: Render, rate_hz: float) -> bool:
    """Run the curses view, then undo what it switched on; whether all was made safe.

    The undo runs after curses has restored the terminal, also when the view
    ends by Ctrl-C, a signal or an error (which then propagates), so
    amplifiers this view enabled are never left on. What it did is printed
    on stderr, one line per board.
    """
    try:
        with stop_on_signals():
            run_curses(controller, render, rate_hz)
    except (Stopped, KeyboardInterrupt):
        pass  # asked to end: as the quit key
    except BaseException:
        leave(controller)
        raise
    return leave(controller)


def leave(controller: Controller) -> bool:
    report, safe = controller.shutdown()
    for line in report:
        print(f"fw1394 watch: {line}", file=sys.stderr)
    return safe
