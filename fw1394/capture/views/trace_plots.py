"""The two figures of ``fw1394 dissect``: latency histogram, latency against size.

matplotlib is optional; :func:`require_matplotlib` says so in one line.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from fw1394.capture.analysis.stats import Stats
from fw1394.packets import TCode, name_of

INSTALL_HINT = "plots need matplotlib: pip install 'fw1394[plot]' (or pip install matplotlib)"


class PlotError(RuntimeError):
    """Plotting is not possible (matplotlib missing, or the file cannot be written)."""


def require_matplotlib() -> Any:
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as pyplot
    except ImportError:
        raise PlotError(INSTALL_HINT) from None
    return pyplot


def plot_latency(stats: Stats, path: str, title: str) -> int:
    """Histogram of transaction times (microseconds); returns how many were drawn."""
    pyplot = require_matplotlib()
    latency = stats.sample.latency / 1000
    figure, axes = pyplot.subplots(figsize=(8, 4.5))
    if len(latency):
        high = float(np.percentile(latency, 99.9)) if len(latency) > 100 else float(latency.max())
        axes.hist(latency[latency <= high], bins=100, color="#3b6ea8")
    axes.set_xlabel("transaction time (µs)")
    axes.set_ylabel("transactions")
    shown = len(latency)
    sampled = (
        "" if stats.sample.seen <= shown else f" (random sample of {shown} of {stats.sample.seen})"
    )
    axes.set_title(f"{title}: {stats.sample.seen} transactions{sampled}")
    _save(figure, path, pyplot)
    return shown


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
    axes.set_xlabel("data length (bytes)")
    axes.set_ylabel("transaction time (µs)")
    axes.set_title(f"{title}: time against size")
    if len(sample.tcode):
        axes.legend(markerscale=3)
    _save(figure, path, pyplot)
    return len(sample.latency)


def _save(figure: Any, path: str, pyplot: Any) -> None:
    try:
        figure.tight_layout()
        figure.savefig(path, dpi=120)
    except OSError as error:
        raise PlotError(f"cannot write {path}: {error.strerror or error}") from None
    finally:
        pyplot.close(figure)
