"""The two figures of ``fw1394 dissect``: latency histogram, latency against size.

matplotlib is optional; :func:`require_matplotlib` says so in one line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from fw1394.capture.analysis.stats import Stats
from fw1394.errors import Error
from fw1394.packets import TCode, name_of

INSTALL_HINT = "plots need matplotlib: pip install 'fw1394[plot]' (or pip install matplotlib)"


class PlotError(Error, RuntimeError):
    """Plotting is not possible (matplotlib missing, or the file cannot be written)."""


def require_matplotlib() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
    except ImportError:
        raise PlotError(INSTALL_HINT) from None
    return pyplot


def check_plot_path(path: str) -> None:
    """Refuse, before any work, a file name whose extension matplotlib cannot write."""
    pyplot = require_matplotlib()
    figure = pyplot.figure()
    try:
        formats = figure.canvas.get_supported_filetypes()
    finally:
        pyplot.close(figure)
    extension = path.rpartition(".")[2].lower() if "." in path.rpartition("/")[2] else ""
    if extension not in formats:
        known = ", ".join(sorted(formats))
        given = f"a .{extension} file" if extension else "a file without an extension"
        raise PlotError(f"{path}: cannot draw {given}; name a .png (or {known})")


#: On traces of more than FULL_RANGE_UP_TO transactions the histogram ends at
#: RANGE_OVER_P99 times the 99th percentile, so a few stragglers (a bus reset, a
#: descheduled process) do not squeeze the rest into one bar; a note counts them.
RANGE_OVER_P99 = 3.0
FULL_RANGE_UP_TO = 100
PERCENTILES = ((50, "p50", "#D55E00", "--"), (99, "p99", "#009E73", ":"))


def plot_latency(stats: Stats, path: str, title: str) -> int:
    """Histogram of transaction times (microseconds); returns how many were drawn."""
    pyplot = require_matplotlib()
    figure = latency_figure(pyplot, stats.sample.latency / 1000, stats.sample.seen, title)
    save_figure(pyplot, figure, path)
    return len(stats.sample.latency)


def latency_figure(pyplot: Any, latency_us: np.ndarray, seen: int, title: str) -> Any:
    """The histogram with p50/p99 markers and a note of what lies past its right edge."""
    from matplotlib.ticker import MaxNLocator

    figure, axes = pyplot.subplots(figsize=(8, 4.5))
    shown = len(latency_us)
    if shown:
        high = float(latency_us.max())
        if shown > FULL_RANGE_UP_TO:
            high = min(high, RANGE_OVER_P99 * float(np.percentile(latency_us, 99)))
        inside = latency_us <= high
        axes.hist(latency_us[inside], bins=min(100, max(10, shown // 5)), color="#56B4E9")
        for share, name, colour, style in PERCENTILES:
            value = float(np.percentile(latency_us, share))
            label = f"{name} {format_us(value)}"
            axes.axvline(value, color=colour, linestyle=style, linewidth=1.5, label=label)
        outside = int(np.count_nonzero(~inside))
        if outside:
            beyond = latency_us[~inside]
            low, top = format_us(float(beyond.min())), format_us(float(beyond.max()))
            note = f"{outside} off scale: " + (top if low == top else f"{low} to {top}")
            axes.text(
                0.98, 0.70, note, transform=axes.transAxes, ha="right", va="top", fontsize=9,
                bbox={"boxstyle": "round", "facecolor": "#FFF3D6", "edgecolor": "#E69F00"},
            )  # fmt: skip
        axes.legend(loc="upper right", fontsize=9)
    axes.yaxis.set_major_locator(MaxNLocator(integer=True))
    axes.set_xlabel("transaction time (µs)")
    axes.set_ylabel("transactions")
    sampled = "" if seen <= shown else f" (random sample of {shown} of {seen})"
    axes.set_title(f"{title}: {seen} transactions{sampled}")
    return figure


def format_us(value: float) -> str:
    """A time in microseconds, in ms from 1000 µs on."""
    return f"{value / 1000:.3g} ms" if value >= 1000 else f"{value:.3g} µs"


def plot_size(stats: Stats, path: str, title: str) -> int:
    """Transaction time against block size, one colour per request kind."""
    pyplot = require_matplotlib()
    sample = stats.sample
    figure, axes = pyplot.subplots(figsize=(8, 4.5))
    for code in np.unique(sample.tcode).tolist():
        chosen = sample.tcode == code
        axes.scatter(
            sample.size[chosen],
            sample.latency[chosen] / 1000,
            s=4,
            alpha=0.4,
            label=name_of(TCode, int(code)),
        )
    sizes = np.unique(sample.size)
    if len(sizes) == 1:
        # One size only: a tick at it, not an axis of fractions around it.
        only = int(sizes[0])
        axes.set_xticks([only])
        axes.set_xlim(only - max(1, only // 2), only + max(1, only // 2))
    axes.set_xlabel("data length (bytes)")
    axes.set_ylabel("transaction time (µs)")
    axes.set_title(f"{title}: time against size")
    if len(sample.tcode):
        axes.legend(markerscale=3)
    save_figure(pyplot, figure, path)
    return len(sample.latency)


def save_figure(pyplot: Any, figure: Any, path: str | Path, *, dpi: int = 120) -> None:
    """Write ``figure`` to ``path`` and close it; a path matplotlib cannot write is a
    :class:`PlotError` (one line for the CLI)."""
    try:
        figure.tight_layout()
        figure.savefig(path, dpi=dpi)
    except OSError as error:
        raise PlotError(f"cannot write {path}: {error.strerror or error}") from None
    except ValueError as error:  # a format matplotlib knows but cannot write here
        raise PlotError(f"cannot write {path}: {error}") from None
    finally:
        pyplot.close(figure)
