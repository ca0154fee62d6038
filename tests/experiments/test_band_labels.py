"""The quadlet figure's band labels: bands a few µs apart get labels that do not overlap."""

from __future__ import annotations

from itertools import pairwise

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.experiments.figures import spread


@given(st.lists(st.floats(0, 200, allow_nan=False), max_size=8), st.floats(0.5, 10))
def test_labels_keep_their_order_a_gap_apart_and_never_go_down(
    positions: list[float], gap: float
) -> None:
    placed = spread(positions, gap)
    assert len(placed) == len(positions)
    assert all(new >= old for new, old in zip(placed, positions, strict=True))
    ordered = sorted(range(len(positions)), key=lambda i: positions[i])
    heights = [placed[i] for i in ordered]
    assert all(b - a >= gap - 1e-9 for a, b in pairwise(heights))


def test_the_reference_runs_crowded_bands() -> None:
    # The write bands of the reference run: 21, 23, 25, 28 µs on an axis of ~80 µs.
    placed = spread([21, 23, 25, 28, 41], 5.6)
    assert placed == pytest.approx([21, 26.6, 32.2, 37.8, 43.4])
