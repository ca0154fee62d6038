"""Progress of a long run on stderr: a rich progress bar per phase on a terminal, plain lines
elsewhere (a log file or a pipe gets a line at 0, 25, 50 and 75 % and one per finished phase).
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

_REDRAW_S = 0.25


class Progress:
    """``start`` a phase, ``update`` it with how much is done, ``note`` a finished result."""

    def __init__(self, stream: TextIO | None = None, *, enabled: bool = True) -> None:
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self._tty = self.stream.isatty()
        self._label = ""
        self._total = 0
        self._started = 0.0
        self._next_draw = 0.0
        self._next_share = 0.0
        self._bar: Any = None  # the rich progress display of the phase, on a terminal

    def start(self, label: str, total: int) -> None:
        self._label, self._total = label, total
        self._started = time.monotonic()
        self._next_draw, self._next_share = 0.0, 0.0
        if self.enabled and self._tty:
            self._stop_bar()
            self._bar = _bar(self.stream)
            self._bar.add_task(label, total=total or None)
            self._bar.start()
        self.update(0)

    def update(self, done: int) -> None:
        # Called once per measured transaction: everything but a clock read is skipped
        # between redraws.
        if not self.enabled:
            return
        now = time.monotonic()
        if self._bar is not None:
            if now < self._next_draw and done < self._total:
                return
            self._next_draw = now + _REDRAW_S
            self._bar.update(self._bar.task_ids[0], completed=done)
            self._bar.refresh()
            return
        share = done / self._total if self._total else 1.0
        if share >= self._next_share:
            # A log file gets a line at 0, 25, 50 and 75 %, not a stream of redraws.
            self._next_share = (int(share * 4) + 1) / 4
            if share < 1.0:
                self._write(self._line(done, share, now) + "\n")

    def finish(self, summary: str = "") -> None:
        if not self.enabled:
            return
        self._stop_bar()
        elapsed = time.monotonic() - self._started
        line = f"{self._label}: done in {elapsed:.1f} s" + (f"; {summary}" if summary else "")
        self._write(line + "\n")

    def note(self, text: str) -> None:
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.console.print(text, highlight=False, markup=False)
        else:
            self._write(text + "\n")

    def _line(self, done: int, share: float, now: float) -> str:
        return f"{self._label}: {done}/{self._total} ({share:.0%}, {now - self._started:.1f} s)"

    def _stop_bar(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()


def _bar(stream: TextIO) -> Any:
    """A transient rich bar (it gives way to the phase's summary line when done)."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        MofNCompleteColumn(),
        TaskProgressColumn(),
        TimeElapsedColumn(),
        console=Console(file=stream),
        transient=True,
        auto_refresh=False,
        # Output of the run goes where it was going (stdout stays the program's data).
        redirect_stdout=False,
        redirect_stderr=False,
    )
