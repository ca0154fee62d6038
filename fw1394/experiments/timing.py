"""Timing transactions one at a time, and where the processes of a run sit on the CPUs."""

from __future__ import annotations

import gc
import os
import time
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager

from fw1394.errors import Error
from fw1394.progress import Progress

#: Give up on a measurement when more than this share of its transactions fail.
MAX_FAILURE_SHARE = 0.05
#: ... but always tolerate this many (a bus reset right at the start costs a few).
FAILURE_ALLOWANCE = 20
#: This many failures in a row: the target has gone (a node that crashed, a stopped server).
CONSECUTIVE_LIMIT = 8
PROGRESS_EVERY = 256
#: Calls made and thrown away at the start of every round after a run's first, raw or
#: target: the first transactions after a switch wake a peer that slept through the
#: other half's round (80-300 us instead of 30-60), a cost of the interleaving
#: itself, not of what the round measures.
SWITCH_WARMUP = 10


class TargetError(Error, RuntimeError):
    """A transaction that did not complete (no answer, bus reset, refused)."""


class MeasurementError(Error, RuntimeError):
    """Too many transactions of a measurement failed for its numbers to mean anything."""


@contextmanager
def collector_paused() -> Iterator[None]:
    """The garbage collector off: a collection inside a transaction is a pause of
    this process, not of the bus, and would be charged to whatever was timed."""
    collecting = gc.isenabled()
    gc.disable()
    try:
        yield
    finally:
        if collecting:
            gc.enable()


class FailureBudget:
    """Counts failed transactions; raises once there are too many for ``planned`` calls."""

    def __init__(self, planned: int) -> None:
        self.limit = max(FAILURE_ALLOWANCE, int(MAX_FAILURE_SHARE * planned))
        self.failures = 0
        self.in_a_row = 0

    def charge(self, error: TargetError) -> None:
        self.failures += 1
        self.in_a_row += 1
        if self.in_a_row >= CONSECUTIVE_LIMIT:
            raise MeasurementError(
                f"the target stopped answering ({self.in_a_row} failures in a row); last: {error}"
            ) from error
        if self.failures > self.limit:
            raise MeasurementError(
                f"{self.failures} transactions failed (at most {self.limit} allowed); last: {error}"
            ) from error


def time_one(action: Callable[[], object], budget: FailureBudget) -> float:
    """Microseconds of one successful ``action()``; failed attempts are charged and repeated."""
    clock = time.perf_counter_ns
    while True:
        start = clock()
        try:
            action()
        except TargetError as error:
            budget.charge(error)
            continue
        elapsed = clock() - start
        budget.in_a_row = 0
        return elapsed / 1000


def time_calls(
    action: Callable[[], object],
    count: int,
    *,
    warmup: int = 0,
    progress: Progress | None = None,
) -> tuple[list[float], int]:
    """``count`` timings of ``action()`` in microseconds, and how many attempts failed.

    The first ``warmup`` calls are made and thrown away (the peer's first
    wake-ups, cold caches). A failed call is not a sample: it is counted and
    the call is repeated.
    """
    budget = FailureBudget(count + warmup)
    samples: list[float] = []
    with collector_paused():
        for _ in range(warmup):
            time_one(action, budget)
        for done in range(count):
            samples.append(time_one(action, budget))
            if progress is not None and done and done % PROGRESS_EVERY == 0:
                progress.update(done)
    return samples, budget.failures


def pin(pids: Iterable[int], cpus: set[int]) -> None:
    """Keep ``pids`` (0: this process) on ``cpus``; processes already gone are skipped."""
    for pid in pids:
        try:
            os.sched_setaffinity(pid, cpus)
        except (ProcessLookupError, PermissionError):
            continue


def cpu_split() -> tuple[set[int], set[int]] | None:
    """(this process's CPUs, its peers' CPUs) for ``--pin``, or None with a single CPU.

    The bench process gets the first CPU it may use; the processes it talks
    to (nodes, the UDP echo) share the others, so that the two ends of a
    round trip never wait for each other's time slice.
    """
    allowed = sorted(os.sched_getaffinity(0))
    if len(allowed) < 2:
        return None
    return {allowed[0]}, set(allowed[1:])
