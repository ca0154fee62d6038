"""Clocks for a fuzzing trial: simulated (in-process, repeatable) or the wall clock.

In-process the trial owns time. It advances by a small step per case, and
now and then by a long jump: a board's watchdog only fires after tens of
milliseconds without a write, which no run of back-to-back cases would reach.
The time handed out moves in quanta of a quarter millisecond (the snake
board's physics step): a board recomputes its motors whenever its clock moves,
and doing that for every case would cost more than the case.
"""

from __future__ import annotations

import random
import time

#: Simulated time per case (the shortest 1394 transaction is about this long).
STEP = 20e-6
#: Share of cases preceded by a long quiet spell, and its length (longer than
#: the QLA's 30 ms watchdog).
JUMP_SHARE = 1 / 512
JUMP = 0.05
#: Granularity of the time handed to the boards.
QUANTUM = 250e-6


class SimulatedClock:
    """Seeded simulated time: ``STEP`` per call, sometimes ``JUMP`` more."""

    def __init__(self, seed: int, start: float = 0.0) -> None:
        self._rng = random.Random(seed)
        self.elapsed = start

    def __call__(self) -> float:
        self.elapsed += STEP + (JUMP if self._rng.random() < JUMP_SHARE else 0.0)
        return self.elapsed - self.elapsed % QUANTUM


class WallClock:
    """Seconds since the trial started (a remote node keeps its own time anyway)."""

    def __init__(self) -> None:
        self._start = time.monotonic()

    def __call__(self) -> float:
        return time.monotonic() - self._start
