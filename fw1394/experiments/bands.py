"""Bands in a distribution of transaction times, as the thesis reads them off Figure 20.

The thesis saw quadlet reads fall in three bands (30, 42, 49 us) and writes
in two (27, 42 us). :func:`find_bands` finds such bands in any sample:

1. Histogram the central 99.8 % of the samples (the slowest 0.1 % are
   scheduler stalls that would stretch the axis) with bins of half the
   Freedman-Diaconis width, IQR / n^(1/3), or of the clock's step if the
   times are quantised more coarsely, and smooth it with a 3-bin triangle.
2. Take the local maxima of the smoothed histogram, highest first, ignoring
   those under 3 % of the highest (sparse scatter in the tail). A maximum is
   a band of its own only if, towards every band already taken, the
   histogram dips to at most ``1 - min_dip`` of its height on the way
   (default: to half). A shoulder or a noise ripple never dips that far.
3. Split the samples at the lowest point between neighbouring bands; every
   sample belongs to one band (outliers to the nearest end band). A band
   with less than ``min_share`` of the samples is dropped and the split
   redone, so a handful of stragglers never makes a band.

A band is reported by the median of its samples, its share and its bounds.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

CENTRAL_RANGE = (0.1, 99.9)
#: Bin width in IQR / n^(1/3): half the Freedman-Diaconis width, so that bands a
#: few microseconds apart stay apart even with a few hundred samples.
FD_FACTOR = 1.0
MAX_BINS = 4000
SMOOTHING = np.array([1.0, 2.0, 1.0]) / 4.0
#: A maximum lower than this share of the highest one is scatter, not a band.
MIN_HEIGHT = 0.03


@dataclass(frozen=True)
class Band:
    """One band: the median of its samples, how many, and where it was split off."""

    center_us: float
    count: int
    share: float
    low_us: float
    high_us: float

    def as_dict(self) -> dict[str, float | int]:
        return {
            "center_us": round(self.center_us, 2),
            "count": self.count,
            "share": round(self.share, 4),
            "low_us": round(self.low_us, 2),
            "high_us": round(self.high_us, 2),
        }


def find_bands(
    samples_us: Sequence[float], *, min_dip: float = 0.5, min_share: float = 0.02
) -> list[Band]:
    """The bands of ``samples_us``, fastest first (empty for no samples)."""
    values = np.sort(np.asarray(samples_us, dtype=float))
    if len(values) == 0:
        return []
    low, high = (float(v) for v in np.percentile(values, CENTRAL_RANGE))
    if high - low <= 0:
        return [_band(values, len(values), -np.inf, np.inf)]
    edges = _bin_edges(values, low, high)
    counts, _ = np.histogram(values, bins=edges)
    smooth = np.convolve(counts.astype(float), SMOOTHING, mode="same")
    peaks = _separate_peaks(smooth, min_dip)
    while True:
        cuts = [edges[_valley(smooth, a, b)] for a, b in pairwise(peaks)]
        bounds = [-np.inf, *cuts, np.inf]
        bands = [_band(values, len(values), lo, hi) for lo, hi in pairwise(bounds)]
        small = [i for i, band in enumerate(bands) if band.share < min_share]
        if not small or len(peaks) == 1:
            return [band for band in bands if band.count]
        # Drop the weakest of the small bands and split again.
        weakest = min(small, key=lambda i: smooth[peaks[i]])
        peaks = peaks[:weakest] + peaks[weakest + 1 :]


def _bin_edges(values: np.ndarray, low: float, high: float) -> np.ndarray:
    q1, q3 = np.percentile(values, [25, 75])
    width = max(FD_FACTOR * (q3 - q1) / len(values) ** (1 / 3), _resolution(values, low, high))
    if width <= 0:
        width = (high - low) / MAX_BINS
    bins = min(max(int(np.ceil((high - low) / width)) + 1, 8), MAX_BINS)
    # Centred on multiples of the width from ``low``: samples of a coarse clock sit mid-bin.
    start = low - width / 2
    edges: np.ndarray = start + width * np.arange(bins + 1)
    return edges


def _resolution(values: np.ndarray, low: float, high: float) -> float:
    """The clock's step if the samples are quantised (most gaps are 0 or one step), else 0."""
    central = values[(values >= low) & (values <= high)]
    steps = np.diff(np.unique(central))
    if len(steps) == 0 or len(np.unique(central)) > len(central) / 4:
        return 0.0
    return float(steps.min())


def _local_maxima(smooth: np.ndarray) -> list[int]:
    padded = np.concatenate(([-np.inf], smooth, [-np.inf]))
    # Strictly above the left neighbour and not below the right: one index per plateau.
    rising = padded[1:-1] > padded[:-2]
    not_falling = padded[1:-1] >= padded[2:]
    return [int(i) for i in np.flatnonzero(rising & not_falling) if smooth[i] > 0]


def _separate_peaks(smooth: np.ndarray, min_dip: float) -> list[int]:
    accepted: list[int] = []
    floor = MIN_HEIGHT * float(smooth.max())
    for peak in sorted(_local_maxima(smooth), key=lambda i: -smooth[i]):
        if smooth[peak] < floor:
            break
        ceiling = (1 - min_dip) * smooth[peak]
        if all(smooth[_valley(smooth, *sorted((peak, other)))] <= ceiling for other in accepted):
            accepted.append(peak)
    return sorted(accepted)


def _valley(smooth: np.ndarray, left: int, right: int) -> int:
    """Index of the lowest bin between two peaks (the first, if several are as low)."""
    return left + int(np.argmin(smooth[left : right + 1]))


def _band(values: np.ndarray, total: int, low: float, high: float) -> Band:
    start, stop = np.searchsorted(values, [low, high], side="left")
    members = values[start:stop]
    if len(members) == 0:
        return Band(float("nan"), 0, 0.0, low, high)
    return Band(
        center_us=float(np.median(members)),
        count=len(members),
        share=len(members) / total,
        low_us=float(members[0]) if low == -np.inf else low,
        high_us=float(members[-1]) if high == np.inf else high,
    )
