"""PNG figures of a run in the thesis's form: Figures 20 (quadlets) and 21 (blocks), and two more.

* ``quadlet.png``: each transaction's time against its iteration, as Figure
  20, with the histogram beside it and the detected bands marked;
* ``block.png``: every block transaction's time against its size, as
  Figure 21, with the fitted lines (and the thesis's, dashed);
* ``servo.png``: control time left per cycle at 1, 8 and 10 kHz;
* ``scale.png``: quadlet read percentiles against the number of boards.

matplotlib is optional: :func:`fw1394.capture.views.trace_plots.require_matplotlib` says so.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fw1394.capture.views.trace_plots import PlotError, require_matplotlib, save_figure
from fw1394.experiments import thesis
from fw1394.experiments.bands import find_bands
from fw1394.experiments.measurements import BlockRun, QuadletRun, ScalePoint
from fw1394.experiments.run import BenchResult

DPI = 80
READ_COLOUR, WRITE_COLOUR = "#3b6ea8", "#c0504d"
#: Times above this percentile, or above this many medians, are left off the axes (and
#: counted in the title): millisecond scheduler stalls would squash the bands flat.
CLIP_PERCENTILE = 99.5
CLIP_MEDIANS = 4.0


def write_plots(result: BenchResult, digest: dict[str, Any], directory: Path) -> list[Path]:
    """Every figure the run has data for; the paths written."""
    pyplot = require_matplotlib()
    try:
        directory.mkdir(parents=True, exist_ok=True)
    except OSError as error:
        raise PlotError(f"cannot create {directory}: {error.strerror or error}") from None
    written = []
    if result.quadlets is not None:
        written.append(_save(pyplot, _quadlets(pyplot, result.quadlets), directory / "quadlet.png"))
    if result.blocks is not None:
        written.append(
            _save(pyplot, _blocks(pyplot, result.blocks, digest), directory / "block.png")
        )
    if "quadlet" in digest["servo"] or "block" in digest["servo"]:
        written.append(_save(pyplot, _servo(pyplot, digest["servo"]), directory / "servo.png"))
    if result.scale:
        written.append(_save(pyplot, _scale(pyplot, result.scale), directory / "scale.png"))
    return written


def _quadlets(pyplot: Any, run: QuadletRun) -> Any:
    from matplotlib.ticker import MaxNLocator

    figure, axes = pyplot.subplots(
        2, 2, figsize=(9, 6), sharey="row", gridspec_kw={"width_ratios": [3, 1]}
    )
    rows = (
        ("read", run.read, READ_COLOUR, thesis.QUADLET_READ_BANDS_US, thesis.QUADLET_READ_MEAN_US),
        (
            "write",
            run.write,
            WRITE_COLOUR,
            thesis.QUADLET_WRITE_BANDS_US,
            thesis.QUADLET_WRITE_MEAN_US,
        ),
    )
    for (trace, histogram), (name, samples, colour, paper_bands, paper_mean) in zip(
        axes, rows, strict=True
    ):
        values = np.asarray(samples)
        top = _ceiling(values)
        shown = values <= top
        trace.scatter(np.flatnonzero(shown), values[shown], s=1, color=colour, rasterized=True)
        trace.set_ylabel("transaction time (µs)")
        trace.set_title(
            f"quadlet {name}: {len(values)} iterations, mean {values.mean():.1f} µs "
            f"(thesis {paper_mean} µs, bands {', '.join(f'{b:.0f}' for b in paper_bands)}); "
            f"{int((~shown).sum())} above {top:.0f} µs not shown",
            fontsize=8,
        )
        histogram.hist(values[shown], bins=120, orientation="horizontal", color=colour)
        bands = find_bands(samples)
        low = float(values[shown].min()) if shown.any() else 0.0
        # Labels of bands a few µs apart would print over each other: each goes at
        # least a line's height above the one below it, the dashed line stays put.
        places = spread([band.center_us for band in bands], LABEL_GAP * max(top - low, 1.0))
        for band, place in zip(bands, places, strict=True):
            histogram.axhline(band.center_us, color="black", linewidth=0.8, linestyle="--")
            histogram.annotate(
                f"{band.center_us:.0f} µs, {band.share:.0%}",
                (0.98, place),
                xycoords=("axes fraction", "data"),
                ha="right",
                va="bottom",
                fontsize=7,
            )
        histogram.set_xlabel("transactions")
        histogram.xaxis.set_major_locator(MaxNLocator(nbins=3, integer=True))
    axes[1][0].set_xlabel("iteration")
    return figure


#: The least distance between two band labels, as a share of the axis's height.
LABEL_GAP = 0.07


def spread(positions: list[float], gap: float) -> list[float]:
    """``positions`` moved up as little as needed for ``gap`` between neighbours,
    in their own order (the lowest stays where it is)."""
    order = sorted(range(len(positions)), key=lambda i: positions[i])
    placed = list(positions)
    previous: float | None = None
    for index in order:
        if previous is not None and placed[index] < previous + gap:
            placed[index] = previous + gap
        previous = placed[index]
    return placed


def _blocks(pyplot: Any, run: BlockRun, digest: dict[str, Any]) -> Any:
    figure, axes = pyplot.subplots(figsize=(9, 5))
    tops = []
    sizes = np.asarray(run.sizes)
    for name, samples, colour, paper_base, paper_mbit in (
        ("read", run.read, READ_COLOUR, thesis.BLOCK_READ_BASE_US, thesis.BLOCK_READ_MBIT_S),
        ("write", run.write, WRITE_COLOUR, thesis.BLOCK_WRITE_BASE_US, thesis.BLOCK_WRITE_MBIT_S),
    ):
        xs = np.concatenate([[size] * len(samples[size]) for size in run.sizes])
        ys = np.concatenate([samples[size] for size in run.sizes])
        tops.append(_ceiling(ys))
        axes.scatter(xs, ys, s=2, color=colour, alpha=0.35, rasterized=True)
        fit = digest["block"][name]
        mbit = fit["mbit_s"]
        axes.plot(
            sizes,
            fit["base_us"] + fit["slope_us_per_quadlet"] * sizes,
            color=colour,
            label=f"fw1394 {name}: {fit['base_us']:.1f} µs + "
            + ("flat" if mbit is None else f"{mbit:.0f} Mbit/s"),
        )
        axes.plot(
            sizes,
            paper_base + 32 / paper_mbit * sizes,
            color=colour,
            linestyle="--",
            label=f"thesis {name}: {paper_base} µs + {paper_mbit:.0f} Mbit/s",
        )
    axes.set_ylim(0, max(tops) * 1.05)
    hidden = sum(
        sum(1 for t in times if t > max(tops) * 1.05)
        for run_samples in (run.read, run.write)
        for times in run_samples.values()
    )
    axes.set_xlabel("block size (quadlets)")
    axes.set_ylabel("transaction time (µs)")
    axes.set_title(
        f"block transactions: {len(run.sizes)} sizes x {run.passes} passes, {hidden} off the "
        "top; lines: least squares through the median of each size",
        fontsize=9,
    )
    axes.legend(fontsize=8, loc="upper left")
    return figure


def _servo(pyplot: Any, servo: dict[str, Any]) -> Any:
    figure, axes = pyplot.subplots(figsize=(8, 4.5))
    rates = servo["rates_hz"]
    series = [
        ("thesis, quadlets", thesis.QUADLET_LOOP_US, "#9fb7d6"),
        ("thesis, blocks", thesis.BLOCK_LOOP_US, "#e3a9a7"),
    ]
    for method, colour in (("quadlet", READ_COLOUR), ("block", WRITE_COLOUR)):
        if method in servo:
            series.append((f"fw1394, {method}s", servo[method]["cycle_us"], colour))
    width = 0.8 / len(series)
    for k, (label, cycle, colour) in enumerate(series):
        left = [1e6 / rate - cycle for rate in rates]
        positions = np.arange(len(rates)) + (k - (len(series) - 1) / 2) * width
        axes.bar(positions, left, width, color=colour, label=f"{label} ({cycle:.0f} µs of bus)")
    axes.axhline(0, color="black", linewidth=0.8)
    axes.set_xticks(np.arange(len(rates)), [f"{rate // 1000} kHz" for rate in rates])
    axes.set_ylabel("control time left per cycle (µs)")
    axes.set_yscale("symlog", linthresh=100)
    axes.set_title(
        f"servo budget, {servo['axes']} axes (below 0: the loop does not fit)", fontsize=9
    )
    axes.legend(fontsize=7)
    return figure


def _scale(pyplot: Any, points: list[ScalePoint]) -> Any:
    figure, axes = pyplot.subplots(figsize=(7, 4.5))
    boards = [point.boards for point in points]
    drawn = []
    for q, style in ((50, "o-"), (90, "s--"), (99, "^:")):
        values = [float(np.percentile(point.reads, q)) for point in points]
        axes.plot(boards, values, style, label=f"p{q}")
        drawn += values
    axes.set_xscale("log", base=2)
    axes.set_xticks(boards, [str(b) for b in boards])
    # Logarithmic: one scheduler stall in the p99 is 30 times the median.
    axes.set_yscale("log")
    log_ticks(axes.yaxis, min(drawn), max(drawn))
    axes.set_xlabel("boards on the bus (plus the host)")
    axes.set_ylabel("quadlet read time (µs, log scale)")
    axes.set_title("quadlet reads of board 0 as the bus grows", fontsize=9)
    axes.legend(fontsize=8)
    return figure


def log_ticks(axis: Any, low: float, high: float) -> None:
    """Label a log axis spanning ``low``..``high`` at 1-2-5 in every decade
    (..., 50, 100, 200, 500, 1,000, ...), at every mantissa when it spans less than a
    decade, and tick the rest without labels: readable over one decade or five."""
    from matplotlib.ticker import LogLocator, NullFormatter, StrMethodFormatter

    wide = high > 10 * low
    labelled = LOG_LABELLED if wide else LOG_LABELLED + LOG_UNLABELLED
    axis.set_major_locator(LogLocator(base=10, subs=labelled))
    axis.set_major_formatter(StrMethodFormatter("{x:,.0f}"))
    axis.set_minor_locator(LogLocator(base=10, subs=LOG_UNLABELLED if wide else ()))
    axis.set_minor_formatter(NullFormatter())


#: Mantissas labelled on a log axis, and the ones only ticked.
LOG_LABELLED = (1.0, 2.0, 5.0)
LOG_UNLABELLED = (3.0, 4.0, 6.0, 7.0, 8.0, 9.0)


def _ceiling(values: np.ndarray) -> float:
    return min(
        float(np.percentile(values, CLIP_PERCENTILE)), CLIP_MEDIANS * float(np.median(values))
    )


def _save(pyplot: Any, figure: Any, path: Path) -> Path:
    save_figure(pyplot, figure, path, dpi=DPI)
    return path
