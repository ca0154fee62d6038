"""One percentile definition, checked against numpy's (an independent implementation).

numpy.percentile's default ("linear", Hyndman and Fan type 7) is the
definition fw1394.percentile documents; hypothesis draws the samples.
"""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

import fw1394
from fw1394.percentile import percentile, percentiles

finite = st.floats(min_value=-1e9, max_value=1e9, allow_nan=False)


@given(st.lists(finite, min_size=1, max_size=60), st.floats(min_value=0, max_value=100))
def test_equals_numpys_default_percentile(samples: list[float], q: float) -> None:
    # Equal up to rounding: the two interpolate in a different order, so samples near
    # 1e9 can differ in the last bits (a relative 1e-12), not by a definition's gap.
    expected = float(np.percentile(samples, q))
    assert percentile(samples, q) == pytest.approx(expected, rel=1e-12, abs=1e-6)


def test_worked_values() -> None:
    hundred = [float(v) for v in range(1, 101)]
    assert percentiles(hundred, (0, 50, 90, 99, 100)) == pytest.approx(
        (1.0, 50.5, 90.1, 99.01, 100.0)
    )
    assert percentile([4.0, 1.0, 3.0, 2.0], 50) == 2.5  # the middle two, averaged
    assert percentile([7.0], 99) == 7.0


def test_no_samples_and_bad_percentiles() -> None:
    assert math.isnan(percentile([], 50))
    with pytest.raises(ValueError, match=r"outside 0\.\.100"):
        percentile([1.0], 101)


def test_no_second_percentile_helper_in_the_library() -> None:
    # The trace histograms estimate percentiles from bins: another question, kept.
    allowed = {"percentile.py", "capture/analysis/stats.py"}
    root = Path(fw1394.__file__).parent
    helpers = re.compile(r"^\s*def _?(percentiles?|quantiles?)\(", re.MULTILINE)
    found = [
        str(path.relative_to(root))
        for path in sorted(root.rglob("*.py"))
        if str(path.relative_to(root)) not in allowed and helpers.search(path.read_text())
    ]
    assert found == []
