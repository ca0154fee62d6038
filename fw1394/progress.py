"""Progress of a long run on stderr, phase by phase: rich's bar on a terminal, plain lines
elsewhere.

A phase is started with what bounds it (a count of steps, a duration, both or
neither) and updated with the steps done and a detail line; it ends with a
summary line that stays. A terminal gets a transient rich bar, redrawn a few
times a second; a log file or a pipe gets a line at 0, 25, 50 and 75 % of a
bounded phase (every :data:`PLAIN_EVERY_S` of an unbounded one) and the summary,
so the log of a long run stays short. The bench's phases and the fuzzer's
campaign and shrinking all report through it.
"""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

__all__ = ["PLAIN_EVERY_S", "Progress"]

_REDRAW_S = 0.25
#: Seconds between two plain lines of a phase nothing bounds.
PLAIN_EVERY_S = 10.0


class Progress:
    """``start`` a phase, ``update`` it with how much is done, ``note`` a result, ``finish``."""

    def __init__(self, stream: TextIO | None = None, *, enabled: bool = True) -> None:
        self.stream = stream or sys.stderr
        self.enabled = enabled
        self._tty = self.stream.isatty()
        self._label = ""
        self._total: int | None = None
        self._duration: float | None = None
        self._started = 0.0
        self._next_draw = 0.0
        self._next_share = 0.0
        self._next_line = 0.0
        self._bar: Any = None  # the rich display of the phase, on a terminal

    def start(self, label: str, total: int | None = None, *, duration: float | None = None) -> None:
        """A new phase of ``total`` steps and/or ``duration`` seconds (neither: unbounded)."""
        self._stop_bar()
        self._label, self._total, self._duration = label, total, duration
        self._started = time.monotonic()
        self._next_draw, self._next_share = 0.0, 0.0
        self._next_line = self._started + PLAIN_EVERY_S
        if self.enabled and self._tty:
            self._bar = _bar(self.stream)
            bounded = bool(total) or bool(duration)
            self._bar.add_task(label, total=1.0 if bounded else None, detail="")
            self._bar.start()
        self.update(0, force=True)

    def update(self, done: int, detail: str = "", *, force: bool = False) -> None:
        """``done`` steps of the phase so far; ``detail`` says more (rates, findings)."""
        # Called in hot loops: everything but a clock read is skipped between redraws.
        if not self.enabled:
            return
        now = time.monotonic()
        share = self._share(done, now)
        if self._bar is not None:
            if now < self._next_draw and not force and (share is None or share < 1.0):
                return
            self._next_draw = now + _REDRAW_S
            task = self._bar.task_ids[0]
            self._bar.update(task, completed=share, detail=self._counted(done, detail))
            self._bar.refresh()
            return
        if share is None:
            if now >= self._next_line or (force and done == 0):
                self._next_line = now + PLAIN_EVERY_S
                self._write(self._line(done, None, now, detail) + "\n")
            return
        if share >= self._next_share and share < 1.0:
            # A log file gets a line at 0, 25, 50 and 75 %, not a stream of redraws.
            self._next_share = (int(share * 4) + 1) / 4
            self._write(self._line(done, share, now, detail) + "\n")

    def finish(self, summary: str = "") -> None:
        """The phase is over: its summary line, which stays on screen and in logs."""
        if not self.enabled:
            return
        self._stop_bar()
        elapsed = time.monotonic() - self._started
        line = f"{self._label}: done in {elapsed:.1f} s" + (f"; {summary}" if summary else "")
        self._write(line + "\n")

    def note(self, text: str) -> None:
        """A line of its own (above the bar on a terminal)."""
        if not self.enabled:
            return
        if self._bar is not None:
            self._bar.console.print(text, highlight=False, markup=False)
        else:
            self._write(text + "\n")

    def close(self) -> None:
        """Take the bar away without a summary (a run that ends early)."""
        self._stop_bar()

    def _share(self, done: int, now: float) -> float | None:
        shares = []
        if self._total:
            shares.append(done / self._total)
        if self._duration:
            shares.append((now - self._started) / self._duration)
        return min(max(shares), 1.0) if shares else None

    def _counted(self, done: int, detail: str) -> str:
        count = f"{done}/{self._total}" if self._total else str(done)
        return f"{count} {detail}".rstrip()

    def _line(self, done: int, share: float | None, now: float, detail: str) -> str:
        shown = f"{share:.0%}, " if share is not None else ""
        text = f"{self._label}: {self._counted(done, '')} ({shown}{now - self._started:.1f} s)"
        return f"{text} {detail}".rstrip()

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
        Progress,
        TaskProgressColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    return Progress(
        TextColumn("{task.description}"),
        BarColumn(),
        TaskProgressColumn(),
        TextColumn("{task.fields[detail]}"),
        TimeElapsedColumn(),
        console=Console(file=stream, highlight=False),
        transient=True,
        auto_refresh=False,
        # Output of the run goes where it was going (stdout stays the program's data).
        redirect_stdout=False,
        redirect_stderr=False,
    )
