"""A one-line progress bar on stderr, redrawn a few times a second: rich's bar on a
terminal, a plain line otherwise (``--progress`` into a pipe or a file)."""

from __future__ import annotations

import sys
import time
from typing import Any, TextIO

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
        bounded = bool(total or duration)
        self._bar: Any = _bar(self.stream, bounded) if self.stream.isatty() else None

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
        if self._bar is not None:
            rate = cases / elapsed if elapsed > 0 else 0.0
            text = f"{cases} cases, {rate:.0f}/s, {findings} findings, {elapsed:.1f} s"
            share = min(max(shares), 1.0) if shares else None
            self._bar.update(self._bar.task_ids[0], completed=share, description=text)
            self._bar.refresh()
            return
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
        if self._bar is not None:
            self._bar.stop()  # the last state stays on screen
        elif self._drawn:
            self.stream.write("\n")
            self.stream.flush()


def _bar(stream: TextIO, bounded: bool) -> Any:
    from rich.console import Console
    from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn

    bar = Progress(
        BarColumn(),
        TaskProgressColumn(),
        TextColumn("{task.description}"),
        console=Console(file=stream, highlight=False),
        auto_refresh=False,
        redirect_stdout=False,  # the campaign's output goes where it was going
        redirect_stderr=False,
    )
    bar.add_task("", total=1.0 if bounded else None)  # no limit: a pulsing bar
    bar.start()
    return bar
