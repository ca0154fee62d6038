"""A one-line progress bar on stderr, redrawn a few times a second."""

from __future__ import annotations

import sys
import time
from typing import TextIO

_WIDTH = 24
_INTERVAL = 0.2


class Progress:
    """Cases done out of ``total`` (or seconds out of ``duration``), rate and findings."""

    def __init__(
        self, total: int | None, duration: float | None, stream: TextIO | None = None
    ) -> None:
        self.total = total
        self.duration = duration
        self.stream = stream or sys.stderr
        self._start = time.monotonic()
        self._next = 0.0
        self._drawn = False

    def update(self, cases: int, findings: int, *, force: bool = False) -> None:
        now = time.monotonic()
        if now < self._next and not force:
            return
        self._next = now + _INTERVAL
        elapsed = now - self._start
        shares = []
        if self.total:
            shares.append(cases / self.total)
        if self.duration:
            shares.append(elapsed / self.duration)
        bar = ""
        if shares:
            filled = int(_WIDTH * min(max(shares), 1.0))
            bar = "[" + "#" * filled + "." * (_WIDTH - filled) + "] "
        rate = cases / elapsed if elapsed > 0 else 0.0
        line = f"{bar}{cases} cases, {rate:.0f}/s, {findings} findings, {elapsed:.1f} s"
        self.stream.write("\r" + line + "\033[K")
        self.stream.flush()
        self._drawn = True

    def close(self) -> None:
        if self._drawn:
            self.stream.write("\n")
            self.stream.flush()
