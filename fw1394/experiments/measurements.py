"""The measurements of §8, against any :class:`~fw1394.experiments.bench_targets.Target`."""

from __future__ import annotations

import random
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import partial
from typing import Protocol

from fw1394.experiments.baseline import Baseline, merged
from fw1394.experiments.bench_targets import BusTarget, Target
from fw1394.experiments.private_bus import PrivateBus
from fw1394.experiments.regime import Regime, settle, switches
from fw1394.experiments.timing import (
    SWITCH_WARMUP,
    FailureBudget,
    collector_paused,
    time_calls,
    time_one,
)
from fw1394.progress import Progress


@dataclass(frozen=True)
class QuadletRun:
    """§8.2: quadlet read and write times (us), one transaction at a time."""

    read: list[float]
    write: list[float]
    failures: int


def measure_quadlets(
    target: Target, iterations: int, *, warmup: int, progress: Progress
) -> QuadletRun:
    progress.start("quadlet reads", iterations)
    reads, read_failures = time_calls(
        target.read_quadlet, iterations, warmup=warmup, progress=progress
    )
    progress.finish()
    progress.start("quadlet writes", iterations)
    writes, write_failures = time_calls(
        target.write_quadlet, iterations, warmup=warmup, progress=progress
    )
    progress.finish()
    return QuadletRun(reads, writes, read_failures + write_failures)


@dataclass(frozen=True)
class BlockRun:
    """§8.3: block read and write times (us) by size in quadlets."""

    sizes: list[int]
    passes: int
    read: dict[int, list[float]] = field(default_factory=dict)
    write: dict[int, list[float]] = field(default_factory=dict)
    failures: int = 0


def measure_blocks(
    target: Target,
    sizes: Sequence[int],
    passes: int,
    *,
    warmup: int,
    progress: Progress,
    seed: int = 1394,
) -> BlockRun:
    """``passes`` sweeps over ``sizes`` in a new random order each, a read and a write per size.

    The shuffle keeps slow drifts of the machine (another job starting, a
    frequency change) from lining up with the block size and tilting the fit.
    """
    order = list(sizes)
    shuffle = random.Random(seed).shuffle
    budget = FailureBudget(2 * len(order) * passes + warmup)
    reads: dict[int, list[float]] = {size: [] for size in order}
    writes: dict[int, list[float]] = {size: [] for size in order}
    progress.start("block reads and writes", len(order) * passes)
    with collector_paused():
        for n in range(warmup):
            size = order[n % len(order)]
            time_one(partial(target.read_block, size), budget)
            time_one(partial(target.write_block, size), budget)
        for sweep in range(passes):
            shuffle(order)
            for done, size in enumerate(order):
                reads[size].append(time_one(partial(target.read_block, size), budget))
                writes[size].append(time_one(partial(target.write_block, size), budget))
                if done and done % 64 == 0:
                    progress.update(sweep * len(order) + done)
    progress.finish()
    return BlockRun(sorted(order), passes, reads, writes, budget.failures)


class RawRounds(Protocol):
    """Rounds of the raw ping-pong (:class:`~fw1394.experiments.baseline.Echo`)."""

    def round(self, count: int, *, warmup: int = 0) -> Baseline: ...


def measure_blocks_interleaved(
    target: Target,
    raw: RawRounds,
    sizes: Sequence[int],
    passes: int,
    *,
    raw_count: int,
    warmup: int,
    progress: Progress,
    regimes: tuple[Regime, Regime] | None = None,
    raw_peers: Sequence[int] = (),
) -> tuple[BlockRun, Baseline]:
    """``passes`` sweeps over ``sizes``, each after a round of ``raw_count`` raw round trips.

    Returns the block times and the raw rounds of these same minutes: the
    unit of the block figures (raw, pass, raw, pass ...). The first pass
    starts after ``warmup`` uncounted transactions, every later round, raw or
    block, after :data:`SWITCH_WARMUP`; every round after a pause that lets
    the other half's processes stop polling (:func:`~fw1394.experiments.regime.settle`).
    ``regimes`` (raw, blocks), if given, count each half's context switches;
    ``raw_peers`` are the processes of the raw rounds (the echo).
    """
    raw_regime, block_regime = regimes or (Regime(), Regime())
    passes_run: list[BlockRun] = []
    floors: list[Baseline] = []
    progress.start("block reads and writes, interleaved", passes)
    for number in range(passes):
        settle()
        before = switches(raw_peers)
        raw_round = raw.round(raw_count, warmup=SWITCH_WARMUP)
        raw_regime.add(before, switches(raw_peers), raw_round.calls + SWITCH_WARMUP)
        floors.append(raw_round)
        settle()
        pass_warmup = warmup if number == 0 else SWITCH_WARMUP
        before = switches(target.peer_pids())
        run = measure_blocks(
            target,
            sizes,
            1,
            warmup=pass_warmup,
            progress=Progress(enabled=False),
            seed=1394 + number,
        )
        calls = 2 * (len(sizes) + pass_warmup) + run.failures
        block_regime.add(before, switches(target.peer_pids()), calls)
        passes_run.append(run)
        progress.update(number + 1)
    progress.finish()
    return _merged_blocks(passes_run), merged(floors)


def _merged_blocks(passes: list[BlockRun]) -> BlockRun:
    reads: dict[int, list[float]] = {}
    writes: dict[int, list[float]] = {}
    for run in passes:
        for size in run.sizes:
            reads.setdefault(size, []).extend(run.read[size])
            writes.setdefault(size, []).extend(run.write[size])
    return BlockRun(
        passes[0].sizes, len(passes), reads, writes, sum(run.failures for run in passes)
    )


@dataclass(frozen=True)
class ScalePoint:
    """Quadlet reads of board 0 with ``boards`` boards (and the host) on the bus."""

    boards: int
    reads: list[float]
    failures: int
    generation: int


def measure_scale(
    bus: PrivateBus,
    board_counts: Sequence[int],
    iterations: int,
    *,
    warmup: int,
    progress: Progress,
) -> list[ScalePoint]:
    """Grow the bench's bus through ``board_counts`` and time quadlet reads of board 0 at each."""
    points = []
    target = BusTarget(bus.port, 0)
    for boards in sorted(board_counts):
        progress.note(f"scale: bringing the bus to {boards} boards ...")
        bus.grow(boards)
        progress.start(f"scale: quadlet reads, {boards} boards", iterations)
        reads, failures = time_calls(
            target.read_quadlet, iterations, warmup=warmup, progress=progress
        )
        progress.finish()
        points.append(ScalePoint(boards, reads, failures, bus.port.generation))
    return points
