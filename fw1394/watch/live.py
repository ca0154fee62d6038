"""Putting the live view together: its frame, and leaving the boards safe however it ends."""

from __future__ import annotations

import signal
import sys
from collections.abc import Iterator
from contextlib import contextmanager
from types import FrameType

from fw1394.errors import Error
from fw1394.watch.controls import KEY_HELP, Controller
from fw1394.watch.conversions import Conversions, watchdog_seconds
from fw1394.watch.screen import Render, run_curses
from fw1394.watch.view import BoardPanel, Line, Style, view_lines

#: The fastest refresh ``fw1394 watch --rate`` offers.
MAX_FEED_HZ = 50.0


def panels(controller: Controller) -> list[BoardPanel]:
    return [BoardPanel(w.node, w.kind, w.reading, w.problem) for w in controller.boards]


def live_render(bus: str, conversions: Conversions, rate_hz: float | None = None) -> Render:
    """The frame of the live view of bus ``bus``, refreshed ``rate_hz`` times a second."""

    def render(controller: Controller, achieved_hz: float, width: int | None = None) -> list[Line]:
        title = f"fw1394 watch  bus {bus}  {len(controller.boards)} board(s)  {achieved_hz:4.1f} Hz"
        if controller.read_only:
            title += "  read-only"
        notice = amplifier_notice(controller, rate_hz or achieved_hz)
        notices = [] if notice is None else [notice]
        footer = [Line(controller.message), Line(KEY_HELP, Style.DIM)]
        return view_lines(
            title, panels(controller), conversions, controller.selected, footer, width, notices
        )

    return render


def amplifier_notice(controller: Controller, rate_hz: float) -> Line | None:
    """What became of the amplifiers this view switched on, as the boards report it.

    The view feeds a board's watchdog once per refresh; a watchdog shorter than
    the refresh period trips between two feeds and switches the amplifiers off,
    which the boards' own status shows, and so must this line.
    """
    held = sorted(controller.enabled_here)
    if not held:
        return None
    interval = 1.0 / rate_hz if rate_hz > 0 else None
    on, tripped, short = 0, set(), {}
    for board, axis in held:
        reading = controller.boards[board].reading
        if reading is None:
            continue
        node = reading.node
        if any(c.axis == axis and c.enabled for c in reading.channels):
            on += 1
        if reading.status.watchdog_timeout:
            tripped.add(node)
        seconds = watchdog_seconds(reading.watchdog_period)
        if reading.watchdog_period and interval is not None and seconds < interval:
            short[node] = seconds
    feed = f"every {interval * 1e3:.0f} ms" if interval is not None else "at each refresh"
    text = f"holding {on} of {len(held)} amplifier(s) enabled here on, feeding the watchdog {feed}"
    if tripped:
        nodes = ",".join(str(node) for node in sorted(tripped))
        text = f"watchdog TIMEOUT on node {nodes}: {on} of {len(held)} amplifier(s) enabled here on"
    if short:
        node, seconds = min(short.items(), key=lambda item: item[1])
        fastest = min(MAX_FEED_HZ, 1.0 / seconds)
        text += (
            f"; node {node}'s {seconds * 1e3:.2f} ms watchdog is shorter than the "
            f"{feed.removeprefix('every ')} between feeds (raise --rate toward "
            f"{fastest:.0f} Hz or the watchdog period)"
        )
    alert = bool(tripped or short or on < len(held))
    return Line(text, Style.ALERT if alert else Style.NORMAL)


class Stopped(Error):
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
