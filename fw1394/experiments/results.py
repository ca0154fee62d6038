"""A run's numbers: summaries, bands, fits, the servo budget and ratios, as one JSON-able dict.

Every latency is also given as a multiple of the raw UDP round trip of the
same run (its median, ``baseline.round_trip.p50_us``): keys starting with
``x_``. The block figures (``x_base``, the block servo cycle) are divided by
the raw rounds interleaved with the block passes alone
(``block.raw_round_trip_p50_us``), the 512-quadlet block times (``x_512``) by
those rounds' round trip with a 2048-byte reply
(``block.raw_block_round_trip_p50_us``). A throughput has no raw
counterpart: on loopback the 2048 bytes themselves cost next to nothing.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fw1394.experiments import servo, thesis
from fw1394.experiments.bands import find_bands
from fw1394.experiments.baseline import Baseline
from fw1394.experiments.fit import LineFit, fit_medians
from fw1394.experiments.frame_floor import FRAMES
from fw1394.experiments.measurements import BlockRun, QuadletRun, ScalePoint
from fw1394.experiments.regime import Regime, same_regime
from fw1394.experiments.run import BenchResult
from fw1394.experiments.summary import summarize

#: The largest S400 block, compared with a raw UDP round trip carrying as much.
LARGEST = thesis.BLOCK_MAX_QUADLETS
STALL_US = 1000.0
FIT_METHOD = "theil-sen line through the median of each size"


def digest(result: BenchResult) -> dict[str, Any]:
    unit = result.baseline.unit_us
    out: dict[str, Any] = {
        "machine": result.machine,
        "settings": result.settings.as_dict(),
        "target": result.target,
        "baseline": result.baseline.as_dict(),
        "thesis": thesis_numbers(),
    }
    fits: dict[str, LineFit] = {}
    block_unit = unit
    if result.quadlets is not None:
        out["quadlet"] = quadlet_section(result.quadlets, unit)
    if result.frame_floor:
        out["frame_floor"] = frame_floor_section(result.frame_floor, result.quadlets, unit)
    if result.blocks is not None and result.block_baseline is not None:
        fits = {
            "read": fit_medians(result.blocks.read),
            "write": fit_medians(result.blocks.write),
        }
        block_unit = result.block_baseline.unit_us
        out["block"] = block_section(result.blocks, fits, result.block_baseline)
    out["servo"] = servo_section(result.quadlets, fits, unit, block_unit)
    if result.scale or result.scale_skipped:
        out["scale"] = scale_section(result.scale, unit, result.scale_skipped)
    if result.regimes:
        out["regime"] = regime_section(result.regimes)
    return out


#: The halves each ratio divides: (raw rounds, target rounds).
RATIO_HALVES = {
    "quadlet": ("raw", "quadlet"),
    "frame_floor": ("raw", "floor"),
    "block": ("block_raw", "block"),
}


def regime_section(regimes: dict[str, Regime]) -> dict[str, Any]:
    """Each half's context switches per call, and whether the halves of each ratio agree."""
    section: dict[str, Any] = {name: regime.as_dict() for name, regime in regimes.items()}
    section["same_regime"] = {
        ratio: same_regime(regimes[raw], regimes[target])
        for ratio, (raw, target) in RATIO_HALVES.items()
        if raw in regimes and target in regimes
    }
    return section


def thesis_numbers() -> dict[str, Any]:
    return {
        "quadlet": {
            "iterations": thesis.QUADLET_ITERATIONS,
            "read": {
                "mean_us": thesis.QUADLET_READ_MEAN_US,
                "bands_us": thesis.QUADLET_READ_BANDS_US,
            },
            "write": {
                "mean_us": thesis.QUADLET_WRITE_MEAN_US,
                "bands_us": thesis.QUADLET_WRITE_BANDS_US,
            },
        },
        "block": {
            "max_quadlets": thesis.BLOCK_MAX_QUADLETS,
            "read": {"base_us": thesis.BLOCK_READ_BASE_US, "mbit_s": thesis.BLOCK_READ_MBIT_S},
            "write": {"base_us": thesis.BLOCK_WRITE_BASE_US, "mbit_s": thesis.BLOCK_WRITE_MBIT_S},
        },
        "servo": {
            "axes": thesis.SERVO_AXES,
            "quadlet": {"cycle_us": thesis.QUADLET_LOOP_US, "left_us": thesis.QUADLET_LEFT_US},
            "block": {"cycle_us": thesis.BLOCK_LOOP_US, "left_us": thesis.BLOCK_LEFT_US},
        },
    }


def quadlet_section(run: QuadletRun, unit: float) -> dict[str, Any]:
    section: dict[str, Any] = {"failures": run.failures}
    for name, samples in (("read", run.read), ("write", run.write)):
        section[name] = {
            **summarize(samples).as_dict(unit),
            "bands": [band.as_dict() for band in find_bands(samples)],
            # Stalls of a millisecond or more: the machine, not the bus (see docs/performance.md).
            "over_1ms": sum(1 for sample in samples if sample >= STALL_US),
        }
    return section


def frame_floor_section(
    samples: list[float], quadlets: QuadletRun | None, unit: float
) -> dict[str, Any]:
    """A quadlet read's three bare frames: what this transport costs before any stack.

    ``read_above_p50_us``: how far the read's median lies above the floor's, the
    work of both ends' stacks and the board.
    """
    floor = summarize(samples)
    section: dict[str, Any] = {"frames": FRAMES, **floor.as_dict(unit)}
    if quadlets is not None and quadlets.read:
        section["read_above_p50_us"] = round(summarize(quadlets.read).p50_us - floor.p50_us, 2)
    return section


def block_section(run: BlockRun, fits: dict[str, LineFit], floor: Baseline) -> dict[str, Any]:
    """Fits, medians by size, and the largest size against raw UDP with a 2048-byte reply.

    ``floor`` is the raw rounds interleaved with the block passes.
    """
    unit, block_unit = floor.unit_us, floor.block_unit_us
    section: dict[str, Any] = {
        "sizes": run.sizes,
        "passes": run.passes,
        "failures": run.failures,
        "fit": FIT_METHOD,
        "raw_round_trip_p50_us": round(unit, 2),
        "raw_block_round_trip_p50_us": round(block_unit, 2),
    }
    for name, samples in (("read", run.read), ("write", run.write)):
        fit = fits[name]
        section[name] = {
            **fit.as_dict(),
            "x_base": round(fit.base_us / unit, 2),
            "median_us": [round(summarize(samples[size]).p50_us, 2) for size in run.sizes],
            "samples_per_size": min(len(samples[size]) for size in run.sizes),
            # How far apart one size's own samples typically lie (the median size's IQR).
            "sample_iqr_us": round(float(np.median([_iqr(samples[s]) for s in run.sizes])), 2),
        }
        if LARGEST in samples:
            largest = summarize(samples[LARGEST]).p50_us
            section[name]["p50_512_us"] = round(largest, 2)
            section[name]["x_512"] = round(largest / block_unit, 2)
    return section


def _iqr(samples: list[float]) -> float:
    low, high = np.percentile(samples, [25, 75])
    return float(high - low)


def servo_section(
    quadlets: QuadletRun | None, fits: dict[str, LineFit], unit: float, block_unit: float
) -> dict[str, Any]:
    section: dict[str, Any] = {
        "axes": thesis.SERVO_AXES,
        "rates_hz": list(thesis.SERVO_RATES_HZ),
    }
    if quadlets is not None:
        read, write = summarize(quadlets.read), summarize(quadlets.write)
        # From the means, as the thesis computes it; medians leave the machine's stalls out.
        cycle = servo.quadlet_loop_us(read.mean_us, write.mean_us)
        typical = servo.quadlet_loop_us(read.p50_us, write.p50_us)
        section["quadlet"] = {
            **servo.budget("quadlet", cycle).as_dict(),
            "x_cycle": round(cycle / unit, 2),
            "from_medians": servo.budget("quadlet-median", typical).as_dict(),
        }
    if fits:
        cycle = servo.block_loop_us(fits["read"], fits["write"])
        section["block"] = {
            **servo.budget("block", cycle).as_dict(),
            "x_cycle": round(cycle / block_unit, 2),
        }
    return section


def scale_section(points: list[ScalePoint], unit: float, skipped: str | None) -> dict[str, Any]:
    if skipped:
        return {"skipped": skipped}
    first = summarize(points[0].reads).p50_us if points else 0.0
    rows = []
    for point in points:
        summary = summarize(point.reads)
        rows.append(
            {
                "boards": point.boards,
                "bus_nodes": point.boards + 1,
                **summary.as_dict(unit),
                "vs_first_p50": round(summary.p50_us / first, 2) if first else None,
                "failures": point.failures,
                "generation": point.generation,
            }
        )
    return {"points": rows}
