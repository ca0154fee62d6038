"""Mean, spread and percentiles of a set of transaction times."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np

from fw1394.percentile import percentiles


@dataclass(frozen=True)
class Summary:
    """Statistics of ``count`` times, all in microseconds.

    Percentiles are :func:`fw1394.percentile.percentiles` (numpy's default
    definition), so p50 of an even count is the mean of the middle two.
    """

    count: int
    mean_us: float
    stdev_us: float
    min_us: float
    p50_us: float
    p90_us: float
    p99_us: float
    max_us: float

    def as_dict(self, unit_us: float | None = None) -> dict[str, float | int]:
        """Rounded fields; with ``unit_us``, each time also as a multiple of it (``x_`` keys)."""
        out: dict[str, float | int] = {
            key: round(value, 2) if isinstance(value, float) else value
            for key, value in asdict(self).items()
        }
        if unit_us:
            for key in ("mean_us", "p50_us", "p90_us", "p99_us"):
                out["x_" + key.removesuffix("_us")] = round(getattr(self, key) / unit_us, 2)
        return out


def summarize(samples_us: Sequence[float]) -> Summary:
    if not samples_us:
        raise ValueError("no samples to summarize")
    values = np.asarray(samples_us, dtype=float)
    p50, p90, p99 = percentiles(samples_us, (50, 90, 99))
    return Summary(
        count=len(values),
        mean_us=float(values.mean()),
        stdev_us=float(values.std(ddof=1)) if len(values) > 1 else 0.0,
        min_us=float(values.min()),
        p50_us=p50,
        p90_us=p90,
        p99_us=p99,
        max_us=float(values.max()),
    )
