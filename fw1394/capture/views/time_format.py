"""``dissect -t``: how the time column of the packet and transaction views is written.

The formats are tshark's: ``r`` seconds since the first record (the default),
``a``/``ad`` local time of day (with the date), ``u``/``ud`` the same in UTC,
``e`` seconds since the epoch, ``d`` seconds since the previous record read,
``dd`` since the previous row shown. In the transaction view ``d`` and ``dd``
both count from the previous transaction shown.
"""

from __future__ import annotations

import time

import numpy as np

FORMATS = {
    "r": "seconds since the first record (default)",
    "a": "local time of day",
    "ad": "local date and time",
    "u": "UTC time of day",
    "ud": "UTC date and time",
    "e": "seconds since 1970-01-01 UTC",
    "d": "seconds since the previous record (transactions: previous shown)",
    "dd": "seconds since the previous row shown",
}
#: Width of the time column the views write for ``r``; other formats replace it.
COLUMN = 14


class TimeColumn:
    """Writes one row's time; remembers what the deltas count from."""

    def __init__(self, kind: str) -> None:
        if kind not in FORMATS:
            raise ValueError(f"unknown time format {kind!r}")
        self.kind = kind
        self.last_shown_ns: int | None = None

    def text(self, ts_ns: int, origin_ns: int, previous_ns: int | None = None) -> str:
        """The time of a row at ``ts_ns``; ``previous_ns`` is the record before it (for ``d``)."""
        kind = self.kind
        if kind == "dd" or (kind == "d" and previous_ns is None):
            previous_ns = self.last_shown_ns
        self.last_shown_ns = ts_ns
        if kind == "r":
            return f"{(ts_ns - origin_ns) / 1e9:>{COLUMN}.9f}"
        if kind in ("d", "dd"):
            delta = 0 if previous_ns is None else ts_ns - previous_ns
            return f"{delta / 1e9:>{COLUMN}.9f}"
        seconds, nanoseconds = divmod(ts_ns, 1_000_000_000)
        if kind == "e":
            return f"{seconds}.{nanoseconds:09d}"
        when = time.gmtime(seconds) if kind.startswith("u") else time.localtime(seconds)
        pattern = "%Y-%m-%d %H:%M:%S" if kind.endswith("d") else "%H:%M:%S"
        return f"{time.strftime(pattern, when)}.{nanoseconds:09d}"

    def unknown(self) -> str:
        """The column for a row whose log had no clock."""
        return f"{'-':>{COLUMN}}"


def previous_times(ts_ns: np.ndarray, before: int | None) -> np.ndarray:
    """The time of the record before each one (-1 for the first record of the trace)."""
    previous = np.empty(len(ts_ns), np.int64)
    if len(ts_ns):
        previous[0] = -1 if before is None else before
        previous[1:] = ts_ns[:-1]
    return previous


def splice(line: str, frame: int, stamp: str) -> str:
    """``line`` with its time column (after the frame number) replaced by ``stamp``."""
    start = len(f"{frame:>7}  ")
    return line[:start] + stamp + line[start + COLUMN :]
