"""Percentiles of measured samples: one definition for every report fw1394 prints.

The definition is the one numpy and R use by default (Hyndman and Fan's
type 7): for ``n`` sorted samples the ``q``-th percentile sits at position
``h = (n - 1) * q / 100``, between the samples either side of it, linearly.
So the 0th is the smallest sample, the 100th the largest, and the 50th of an
even count is the mean of the middle two. Plain Python: the demo and the
benchmarks need it without numpy.

(:class:`fw1394.capture.analysis.stats.LatencyHistograms` estimates
percentiles of traces too large to keep, from histogram bins; it is a
different question and keeps its own rank rule.)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

__all__ = ["percentile", "percentiles"]


def percentiles(samples: Iterable[float], qs: Sequence[float]) -> tuple[float, ...]:
    """The ``qs`` percentiles (each 0..100) of ``samples``; NaN each for no samples."""
    ordered = sorted(samples)
    for q in qs:
        if not 0 <= q <= 100:
            raise ValueError(f"percentile {q} is outside 0..100")
    if not ordered:
        return tuple(math.nan for _ in qs)
    found = []
    for q in qs:
        position = (len(ordered) - 1) * q / 100
        below = math.floor(position)
        above = min(below + 1, len(ordered) - 1)
        found.append(ordered[below] + (position - below) * (ordered[above] - ordered[below]))
    return tuple(found)


def percentile(samples: Iterable[float], q: float) -> float:
    """The ``q``-th percentile (0..100) of ``samples``; NaN for no samples."""
    (value,) = percentiles(samples, (q,))
    return value
