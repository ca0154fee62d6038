"""One bench run: the baseline, then each experiment, into one :class:`BenchResult`."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass, field

import fw1394
from fw1394.experiments import baseline
from fw1394.experiments.baseline import Baseline
from fw1394.experiments.connect import TargetSpec, open_target
from fw1394.experiments.measurements import (
    BlockRun,
    QuadletRun,
    ScalePoint,
    measure_blocks,
    measure_quadlets,
    measure_scale,
)
from fw1394.experiments.phase_progress import Progress
from fw1394.experiments.run_settings import Settings
from fw1394.experiments.timing import cpu_split, pin


@dataclass
class BenchResult:
    """Every sample of a run, and what it ran on; :mod:`fw1394.experiments.results` digests it."""

    settings: Settings
    target: dict[str, object]
    machine: dict[str, object]
    baseline: Baseline
    quadlets: QuadletRun | None = None
    blocks: BlockRun | None = None
    scale: list[ScalePoint] = field(default_factory=list)
    scale_skipped: str | None = None


def machine_info(pinned: bool) -> dict[str, object]:
    return {
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "system": f"{platform.system()} {platform.release()}",
        "fw1394": fw1394.__version__,
        "pinned": pinned,
        "load_average_before": [round(v, 2) for v in os.getloadavg()],
        "started": time.strftime("%Y-%m-%d %H:%M:%S %z"),
    }


def run_bench(
    spec: TargetSpec,
    settings: Settings,
    *,
    board: str = "snake2010",
    board_id: int | None = None,
    pin_cpus: bool = False,
    progress: Progress | None = None,
    timeout: float = 60.0,
) -> BenchResult:
    progress = progress or Progress(enabled=False)
    split = cpu_split() if pin_cpus else None
    own_cpus = os.sched_getaffinity(0)
    try:
        if split is not None:
            pin([0], split[0])
        return _measure(spec, settings, board, board_id, split, progress, timeout)
    finally:
        pin([0], own_cpus)  # a library caller gets its process back as it was


def _measure(
    spec: TargetSpec,
    settings: Settings,
    board: str,
    board_id: int | None,
    split: tuple[set[int], set[int]] | None,
    progress: Progress,
    timeout: float,
) -> BenchResult:
    peers = None if split is None else split[1]
    machine = machine_info(split is not None)
    floor = baseline.measure(
        settings.baseline_iterations, warmup=settings.warmup, cpus=peers, progress=progress
    )
    progress.note("starting the target ...")
    with open_target(spec, board=board, board_id=board_id, peer_cpus=peers, timeout=timeout) as (
        target,
        bus,
    ):
        result = BenchResult(settings, target.describe(), machine, floor)
        if peers is not None:
            pin(target.peer_pids(), peers)
        if settings.runs("quadlet"):
            result.quadlets = measure_quadlets(
                target, settings.quadlet_iterations, warmup=settings.warmup, progress=progress
            )
        if settings.runs("block"):
            result.blocks = measure_blocks(
                target,
                settings.block_sizes,
                settings.block_passes,
                warmup=min(settings.warmup, 100),
                progress=progress,
            )
        if settings.runs("scale"):
            if bus is None:
                result.scale_skipped = (
                    "needs the bench's own bus (the default target): growing another "
                    "bus to 63 nodes would reset it dozens of times under its users"
                )
            else:
                result.scale = measure_scale(
                    bus,
                    settings.scale_boards,
                    settings.scale_iterations,
                    warmup=min(settings.warmup, 200),
                    progress=progress,
                )
    machine["load_average_after"] = [round(v, 2) for v in os.getloadavg()]
    return result
