"""The demo's summary numbers and its plot of commanded versus measured positions."""

from __future__ import annotations

import io
import json
import math
import statistics
from pathlib import Path
from typing import Any

from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.demo.run import DemoResult
from fw1394.percentile import percentile
from fw1394.transport.media.idle import crowded


def tracking_errors(result: DemoResult) -> list[float]:
    """RMS of commanded minus measured position per axis (counts), over the samples."""
    axes = len(result.commanded[0]) if result.commanded else 0
    return [
        math.sqrt(
            statistics.fmean(
                (c[axis] - m[axis]) ** 2
                for c, m in zip(result.commanded, result.measured, strict=True)
            )
        )
        for axis in range(axes)
    ]


def summary(result: DemoResult) -> dict[str, Any]:
    """The numbers the demo prints (microseconds for times)."""
    micro = 1e6
    return {
        "bus": result.bus_name,
        "cycles": result.cycles,
        "seconds": round(result.seconds, 3),
        "rate_hz": round(result.cycles / result.seconds, 1) if result.seconds else 0.0,
        "period_us": {
            name: round(percentile(result.periods, q) * micro, 1)
            for name, q in (("p50", 50), ("p99", 99), ("max", 100))
        },
        "cycle_bus_time_us": {
            name: round(percentile(result.cycle_bus_times, q) * micro, 1)
            for name, q in (("p50", 50), ("p99", 99), ("max", 100))
        },
        "transactions_per_cycle": round(sum(result.servo_transactions.values()) / result.cycles, 2)
        if result.cycles
        else 0.0,
        "transactions_by_kind": result.transactions_by_kind,
        "servo_transactions_by_kind": result.servo_transactions,
        "per_cycle_by_process": result.processes,
        # The goals' figures: every measured process together, and the share of
        # cycles that started late.
        "cpu_us_per_cycle": round(sum(p["cpu_us"] for p in result.processes.values()), 1),
        "cpus_busy": round(
            sum(p["cpu_us"] for p in result.processes.values())
            * result.cycles
            / result.seconds
            / 1e6,
            3,
        )
        if result.seconds
        else 0.0,
        "overrun_percent": round(100 * result.overruns / result.cycles, 2)
        if result.cycles
        else 0.0,
        "idle": {
            "strategy": result.idle,
            "medium": result.medium,
            "members_here": result.members_here,
            "cpus": result.cpus,
            # More members on this host than CPUs: adaptive members block (never poll).
            "crowded": crowded(result.members_here, result.cpus),
        },
        "overruns": result.overruns,
        "watchdog_trips": result.watchdog_trips,
        "bus_resets": result.bus_resets,
        "tracking_rms_counts": [round(e, 1) for e in tracking_errors(result)],
    }


#: Commanded and measured in colours apart in hue and lightness (the Okabe-Ito palette,
#: readable with the common colour-vision deficiencies and in greyscale).
COMMANDED_COLOUR = "#E69F00"
MEASURED_COLOUR = "#0072B2"
COMMANDED_LABEL = "commanded"
MEASURED_LABEL = "measured"
ERROR_TITLE = "tracking error (commanded - measured)"


def axis_title(axis: int) -> str:
    board, channel = ("actuation", axis + 1) if axis < 7 else ("Z-Theta", axis - 6)
    return f"axis {axis + 1} ({board} ch {channel})"


def figure_of(result: DemoResult) -> Any:
    """Commanded and measured position per axis, and every axis's tracking error."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    axes_count = len(result.commanded[0])
    columns = 4
    rows = math.ceil((axes_count + 1) / columns)  # one more panel: the tracking error
    figure, grid = plt.subplots(rows, columns, figsize=(13, 2.4 * rows), sharex=True)
    flat = list(grid.flat)
    errors = flat[axes_count]
    for axis in range(axes_count):
        panel = flat[axis]
        commanded = [c[axis] - ENCODER_MIDPOINT for c in result.commanded]
        measured = [m[axis] - ENCODER_MIDPOINT for m in result.measured]
        panel.plot(result.times, measured, color=MEASURED_COLOUR, lw=1.6, label=MEASURED_LABEL)
        panel.plot(
            result.times, commanded, "--", color=COMMANDED_COLOUR, lw=1.2, label=COMMANDED_LABEL
        )
        error = [c - m for c, m in zip(commanded, measured, strict=True)]
        errors.plot(result.times, error, lw=0.9, label=f"{axis + 1}")
        panel.set_title(axis_title(axis), fontsize=9)
        panel.tick_params(labelsize=7)
    errors.axhline(0, color="black", lw=0.6)
    errors.set_title(ERROR_TITLE, fontsize=9)
    errors.tick_params(labelsize=7)
    errors.set_ylabel("counts", fontsize=8)
    errors.legend(title="axis", fontsize=5, title_fontsize=6, ncol=4, framealpha=0.5)
    for panel in flat[axes_count + 1 :]:
        panel.axis("off")
    flat[0].legend(fontsize=7)
    for panel in flat[-columns:]:
        panel.set_xlabel("time (s)", fontsize=8)
        panel.xaxis.set_tick_params(labelbottom=True)
    figure.suptitle(
        f"fw1394 demo: {axes_count} axes at {result.cycles / max(result.seconds, 1e-9):.0f} Hz "
        "over the virtual 1394 bus (encoder counts from midpoint)",
        fontsize=10,
    )
    figure.tight_layout()
    return figure


def plot(result: DemoResult, path: Path) -> None:
    """Save :func:`figure_of` as a PNG."""
    import matplotlib.pyplot as plt

    figure = figure_of(result)
    figure.savefig(path, dpi=90)
    plt.close(figure)


def traffic(path: Path) -> dict[str, Any]:
    """The dissector's statistics of the demo's capture (``fw1394 dissect --stats``)."""
    from fw1394.capture.formats import sources
    from fw1394.capture.views.dissection import Dissection, Options

    out = io.StringIO()
    try:
        jobs = sources.jobs(str(path), sources.detect(str(path)))
        Dissection(Options(view="stats", output="json"), out).run(jobs)
    except sources.SourceError as error:
        return {"error": str(error)}
    stats: dict[str, Any] = json.loads(out.getvalue().splitlines()[-1])
    return stats
