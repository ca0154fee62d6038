"""What each process of the demo spent per servo cycle: CPU time and wake-ups.

Read from ``/proc/PID/stat`` (user and system time, in clock ticks) and
``/proc/PID/status`` (context switches: a voluntary one is a sleep, so the
next run is a wake-up; an involuntary one is a preemption). Taken before and
after the servo loop, the differences divided by the cycles are what one
cycle costs each process. Clock ticks are coarse (10 ms at the usual 100 Hz),
so a few thousand cycles resolve the CPU time to a few microseconds.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path

_TICK_SECONDS = 1.0 / os.sysconf("SC_CLK_TCK")
#: Fields 14 and 15 of /proc/PID/stat (utime, stime), counted after the ")" of the name.
_UTIME_AFTER_NAME = 11


@dataclass(frozen=True)
class Usage:
    """One process's counters at one moment."""

    cpu_seconds: float
    voluntary_switches: int
    involuntary_switches: int


def usage(pid: int) -> Usage | None:
    """The counters of process ``pid``; None if it is gone."""
    try:
        stat = Path(f"/proc/{pid}/stat").read_text()
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    fields = stat.rsplit(")", 1)[1].split()
    ticks = int(fields[_UTIME_AFTER_NAME]) + int(fields[_UTIME_AFTER_NAME + 1])
    switches = {
        name: int(value)
        for name, _, value in (line.partition(":") for line in status.splitlines())
        if name.endswith("ctxt_switches")
    }
    return Usage(
        cpu_seconds=ticks * _TICK_SECONDS,
        voluntary_switches=int(switches["voluntary_ctxt_switches"]),
        involuntary_switches=int(switches["nonvoluntary_ctxt_switches"]),
    )


def children(pid: int) -> list[int]:
    """The child processes of ``pid`` (every thread's)."""
    found: list[int] = []
    try:
        for task in Path(f"/proc/{pid}/task").iterdir():
            found += [int(child) for child in (task / "children").read_text().split()]
    except OSError:
        return []
    return found


def snapshot(pids: dict[str, int]) -> dict[str, Usage]:
    """:func:`usage` of every named process still running."""
    return {name: u for name, pid in pids.items() if (u := usage(pid)) is not None}


def per_cycle(
    before: dict[str, Usage], after: dict[str, Usage], cycles: int
) -> dict[str, dict[str, float]]:
    """CPU µs, wake-ups and preemptions per cycle of each process seen both times."""
    if not cycles:
        return {}
    return {
        name: {
            "cpu_us": round((after[name].cpu_seconds - start.cpu_seconds) / cycles * 1e6, 1),
            "wakeups": round(
                (after[name].voluntary_switches - start.voluntary_switches) / cycles, 2
            ),
            "preemptions": round(
                (after[name].involuntary_switches - start.involuntary_switches) / cycles, 2
            ),
        }
        for name, start in before.items()
        if name in after
    }


def wait_idle(pid: int, quiet: float = 0.1, limit: float = 5.0) -> None:
    """Return once process ``pid`` used no CPU for ``quiet`` seconds (or after ``limit``)."""
    deadline = time.monotonic() + limit
    last = usage(pid)
    while last is not None and time.monotonic() < deadline:
        time.sleep(quiet)
        now = usage(pid)
        if now is None or now.cpu_seconds == last.cpu_seconds:
            return
        last = now
