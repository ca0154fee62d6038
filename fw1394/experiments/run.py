"""One bench run: the baseline, then each experiment, into one :class:`BenchResult`."""

from __future__ import annotations

import os
import platform
import time
from dataclasses import dataclass, field

from fw1394.experiments import baseline
from fw1394.experiments.baseline import Baseline
from fw1394.experiments.bench_targets import Target
from fw1394.experiments.connect import TargetSpec, open_target
from fw1394.experiments.frame_floor import FrameFloor
from fw1394.experiments.measurements import (
    BlockRun,
    QuadletRun,
    ScalePoint,
    measure_blocks_interleaved,
    measure_quadlets,
    measure_scale,
)
from fw1394.experiments.private_bus import PrivateBus
from fw1394.experiments.regime import Regime, settle, settle_time, switches
from fw1394.experiments.run_settings import Settings
from fw1394.experiments.summary import summarize
from fw1394.experiments.timing import SWITCH_WARMUP, cpu_split, pin
from fw1394.progress import Progress
from fw1394.transport.media.choice import medium_name
from fw1394.transport.media.idle import default_idle
from fw1394.transport.sansio.config import BusConfig
from fw1394.version import __version__

#: Rounds the baseline and the quadlet figures alternate in.
ROUNDS = 10


@dataclass
class BenchResult:
    """Every sample of a run, and what it ran on; :mod:`fw1394.experiments.results` digests it."""

    settings: Settings
    target: dict[str, object]
    machine: dict[str, object]
    baseline: Baseline
    quadlets: QuadletRun | None = None
    blocks: BlockRun | None = None
    #: The raw rounds interleaved with the block passes: the unit of the block figures.
    block_baseline: Baseline | None = None
    scale: list[ScalePoint] = field(default_factory=list)
    scale_skipped: str | None = None
    #: Context switches of each half of the interleaved rounds: "raw", "floor" and
    #: "quadlet", "block_raw" and "block" (:mod:`fw1394.experiments.regime`).
    regimes: dict[str, Regime] = field(default_factory=dict)
    #: A quadlet read's three frames with no work done, timed in the quadlet rounds
    #: (:mod:`fw1394.experiments.frame_floor`); None for a target of another transport.
    frame_floor: list[float] | None = None


def machine_info(pinned: bool) -> dict[str, object]:
    return {
        "cpus": os.cpu_count(),
        "python": platform.python_version(),
        "system": f"{platform.system()} {platform.release()}",
        "fw1394": __version__,
        "pinned": pinned,
        "load_average_before": [round(v, 2) for v in os.getloadavg()],
        # How every process of the run waited for frames (the echo included).
        "idle": str(default_idle()),
        # What a loopback bus of the run carries its frames on (FW1394_MEDIUM).
        "medium": medium_name(BusConfig()),
        # How long each round switch waits for the other half to stop polling.
        "round_switch_settle_ms": round(settle_time(default_idle()) * 1000, 3),
        "interleaved_rounds": ROUNDS,
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
    echo = baseline.Echo(peers)
    frames: FrameFloor | None = None
    try:
        # A read's bare frames are the floor of the virtual bus; Eth1394 is another transport.
        if spec.kind != "udp" and settings.runs("quadlet"):
            frames = FrameFloor(peers)
        progress.note("starting the target ...")
        with open_target(
            spec, board=board, board_id=board_id, peer_cpus=peers, timeout=timeout
        ) as (target, bus):
            if peers is not None:
                pin(target.peer_pids(), peers)
            regimes = {"raw": Regime(), "quadlet": Regime()}
            raw, quadlets, floor = _interleaved(echo, frames, target, settings, progress, regimes)
            result = BenchResult(settings, target.describe(), machine, raw, quadlets)
            result.frame_floor = floor
            result.regimes = regimes
            _the_rest(echo, result, target, bus, settings, progress)
    finally:
        echo.close()
        if frames is not None:
            frames.close()
    machine["load_average_after"] = [round(v, 2) for v in os.getloadavg()]
    return result


def _interleaved(
    echo: baseline.Echo,
    frames: FrameFloor | None,
    target: Target,
    settings: Settings,
    progress: Progress,
    regimes: dict[str, Regime],
) -> tuple[Baseline, QuadletRun | None, list[float] | None]:
    """The baseline, and the quadlet figures and the frame floor if asked for, in
    alternating rounds.

    Round by round (raw, floor, target, raw, floor, target ...) every half of
    each ratio sees the same load on a shared machine; one block of each would
    compare minutes that may differ by a factor of three. Each round starts
    once the other halves' processes have stopped polling
    (:func:`~fw1394.experiments.regime.settle`), and ``regimes`` counts each
    half's context switches.
    """
    echo_pids = [echo.echo.pid]
    if not settings.runs("quadlet"):
        progress.start("raw UDP ping-pong", settings.baseline_iterations)
        before = switches(echo_pids)
        raw = echo.round(settings.baseline_iterations, warmup=settings.warmup)
        regimes["raw"].add(before, switches(echo_pids), raw.calls + settings.warmup)
        progress.finish(f"median {summarize(raw.small).p50_us:.1f} us")
        del regimes["quadlet"]
        return raw, None, None
    if frames is not None:
        regimes["floor"] = Regime()
    quiet = Progress(enabled=False)
    raws: list[Baseline] = []
    runs: list[QuadletRun] = []
    floor: list[float] = []
    progress.start("raw UDP ping-pong and quadlets, interleaved", ROUNDS)
    for number in range(ROUNDS):
        warmup = settings.warmup if number == 0 else SWITCH_WARMUP
        settle()
        before = switches(echo_pids)
        raw = echo.round(max(settings.baseline_iterations // ROUNDS, 10), warmup=warmup)
        regimes["raw"].add(before, switches(echo_pids), raw.calls + warmup)
        raws.append(raw)
        iterations = max(settings.quadlet_iterations // ROUNDS, 10)
        if frames is not None:
            settle()
            before = switches([frames.pid])
            samples, failures = frames.round(iterations, warmup=warmup)
            regimes["floor"].add(before, switches([frames.pid]), iterations + warmup + failures)
            floor += samples
        settle()
        before = switches(target.peer_pids())
        run = measure_quadlets(target, iterations, warmup=warmup, progress=quiet)
        calls = len(run.read) + len(run.write) + 2 * warmup + run.failures
        regimes["quadlet"].add(before, switches(target.peer_pids()), calls)
        runs.append(run)
        progress.update(number + 1)
    merged = baseline.merged(raws)
    progress.finish(f"raw median {summarize(merged.small).p50_us:.1f} us")
    quadlets = QuadletRun(
        [s for run in runs for s in run.read],
        [s for run in runs for s in run.write],
        sum(run.failures for run in runs),
    )
    return merged, quadlets, floor if frames is not None else None


def _the_rest(
    echo: baseline.Echo,
    result: BenchResult,
    target: Target,
    bus: PrivateBus | None,
    settings: Settings,
    progress: Progress,
) -> None:
    if settings.runs("block"):
        block_regimes = (Regime(), Regime())
        result.regimes["block_raw"], result.regimes["block"] = block_regimes
        result.blocks, result.block_baseline = measure_blocks_interleaved(
            target,
            echo,
            settings.block_sizes,
            settings.block_passes,
            raw_count=max(settings.baseline_iterations // ROUNDS, 10),
            warmup=min(settings.warmup, 100),
            progress=progress,
            regimes=block_regimes,
            raw_peers=[echo.echo.pid],
        )
        result.baseline = baseline.merged([result.baseline, result.block_baseline])
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
