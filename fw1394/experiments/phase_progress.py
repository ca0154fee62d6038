"""Progress of a long run on stderr: one line per phase, redrawn in place on a terminal."""

from __future__ import annotations

import sys
import time
from typing import TextIO

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

    def start(self, label: str, total: int) -> None:
        self._label, self._total = label, total
        self._started = time.monotonic()
        self._next_draw, self._next_share = 0.0, 0.25
        self.update(0)

    def update(self, done: int) -> None:
        if not self.enabled:
            return
        share = done / self._total if self._total else 1.0
        now = time.monotonic()
        if self._tty:
            if now < self._next_draw and done < self._total:
                return
            self._next_draw = now + _REDRAW_S
            self._write(f"\r{self._line(done, share, now)}\033[K")
        elif share >= self._next_share or done == 0:
            # A log file gets a line at 0, 25, 50 and 75 %, not a stream of redraws.
            self._next_share = (int(share * 4) + 1) / 4
            if share < 1.0:
                self._write(self._line(done, share, now) + "\n")

    def finish(self, summary: str = "") -> None:
        if not self.enabled:
            return
        elapsed = time.monotonic() - self._started
        line = f"{self._label}: done in {elapsed:.1f} s" + (f"; {summary}" if summary else "")
        self._write(("\r" if self._tty else "") + line + ("\033[K" if self._tty else "") + "\n")

    def note(self, text: str) -> None:
        if self.enabled:
            self._write(text + "\n")

    def _line(self, done: int, share: float, now: float) -> str:
        return f"{self._label}: {done}/{self._total} ({share:.0%}, {now - self._started:.1f} s)"

    def _write(self, text: str) -> None:
        self.stream.write(text)
        self.stream.flush()
