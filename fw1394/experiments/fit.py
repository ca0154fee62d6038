"""Transaction time against block size: a straight line, as the thesis reads Figure 21.

Its intercept is the base latency (the cost of a transaction carrying no
data); its slope, microseconds per quadlet, gives the throughput: 32 bits
per slope microseconds is ``32 / slope`` Mbit/s.

Every line the bench reports is fitted the same way, in two robust steps:
the median of each size's samples, then the Theil-Sen line through those
medians (the median of the slopes between every two sizes, and the median
intercept under that slope). A stall or a cold transaction moves a size's
median only if it is half of that size's samples; a whole size gone wrong
moves the line only if it is most of the sizes. Least squares would let
either pull the intercept, which is the figure most read.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np

BITS_PER_QUADLET = 32


@dataclass(frozen=True)
class LineFit:
    """``time_us = base_us + slope_us_per_quadlet * quadlets``, and how well it fits.

    ``r_squared`` is the share of the points' variance the line explains,
    1 - (sum of squared residuals) / (sum of squared deviations from the mean);
    for a robust line it can be below 0, when the line misses the points by
    more than their own spread. ``residual_iqr_us`` is the interquartile range
    of the residuals: how far from the line the middle half of the points lie.
    """

    base_us: float
    slope_us_per_quadlet: float
    r_squared: float
    residual_iqr_us: float
    points: int

    @property
    def mbit_s(self) -> float | None:
        """Throughput from the slope; None when the time does not grow with the size."""
        if self.slope_us_per_quadlet <= 0:
            return None
        return BITS_PER_QUADLET / self.slope_us_per_quadlet

    def at(self, quadlets: int) -> float:
        """The fitted time of a transaction of ``quadlets`` quadlets."""
        return self.base_us + self.slope_us_per_quadlet * quadlets

    def as_dict(self) -> dict[str, float | int | None]:
        mbit_s = self.mbit_s
        return {
            "base_us": round(self.base_us, 2),
            "slope_us_per_quadlet": round(self.slope_us_per_quadlet, 5),
            "mbit_s": None if mbit_s is None else round(mbit_s, 1),
            "r_squared": round(self.r_squared, 4),
            "residual_iqr_us": round(self.residual_iqr_us, 2),
            "points": self.points,
        }


def fit_line(sizes: Sequence[float], times_us: Sequence[float]) -> LineFit:
    """The Theil-Sen line of ``times_us`` on ``sizes`` (at least two distinct sizes).

    Every pair of points is one slope, n (n - 1) / 2 of them: meant for one
    point per size (at most 512), not for every sample of a run.
    """
    x = np.asarray(sizes, dtype=float)
    y = np.asarray(times_us, dtype=float)
    if len(x) != len(y):
        raise ValueError(f"{len(x)} sizes but {len(y)} times")
    if len(np.unique(x)) < 2:
        raise ValueError("a line needs at least two distinct sizes")
    first, second = np.triu_indices(len(x), k=1)
    run = x[second] - x[first]
    apart = run != 0
    slope = float(np.median((y[second] - y[first])[apart] / run[apart]))
    base = float(np.median(y - slope * x))
    residual = y - (base + slope * x)
    spread = float(((y - y.mean()) ** 2).sum())
    r_squared = 1.0 - float((residual**2).sum()) / spread if spread > 0 else 1.0
    low, high = np.percentile(residual, [25, 75])
    return LineFit(base, slope, r_squared, float(high - low), len(x))


def fit_medians(samples_by_size: Mapping[int, Sequence[float]]) -> LineFit:
    """The line through the median time of each size.

    Medians, not every sample: a scheduler stall of a few milliseconds would
    otherwise tilt the line, and the thesis too reads the line through the
    bulk of the points, not through its sporadic outliers (§8.4).
    """
    sizes = sorted(size for size, times in samples_by_size.items() if len(times))
    medians = [float(np.median(samples_by_size[size])) for size in sizes]
    return fit_line(sizes, medians)
