"""``fw1394 bench`` scale figure: log ticks labelled where the data is, and legible."""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np
import pytest

from fw1394.capture.views.trace_plots import require_matplotlib
from fw1394.experiments.figures import _scale
from fw1394.experiments.measurements import ScalePoint

pyplot = require_matplotlib()


def points(typical_us: float, stall_us: float) -> list[ScalePoint]:
    """Reads of ``typical_us`` growing with the bus, with a few stalls in the tail."""
    rng = np.random.default_rng(5)
    made = []
    for boards in (1, 2, 4, 8):
        reads = rng.normal(typical_us * (1 + boards / 8), typical_us / 20, 400).tolist()
        made.append(ScalePoint(boards, reads + [stall_us * boards] * 6, 0, 1))
    return made


def visible_labels(axes: Any) -> list[tuple[float, str, Any]]:
    low, high = axes.get_ylim()
    renderer = axes.figure.canvas.get_renderer()
    return [
        (tick.get_loc(), tick.label1.get_text(), tick.label1.get_window_extent(renderer))
        for tick in axes.yaxis.get_major_ticks()
        if low <= tick.get_loc() <= high and tick.label1.get_visible() and tick.label1.get_text()
    ]


@pytest.mark.parametrize(
    ("typical_us", "stall_us"),
    [(60.0, 1500.0), (40.0, 80.0), (300.0, 20_000.0)],
    ids=["two decades", "within one decade", "above 100 us"],
)
def test_ticks_are_labelled_throughout_and_do_not_overlap(
    typical_us: float, stall_us: float
) -> None:
    figure = _scale(pyplot, points(typical_us, stall_us))
    try:
        figure.canvas.draw()
        (axes,) = figure.axes
        labels = visible_labels(axes)
        _, high = axes.get_ylim()
        assert len(labels) >= 3, labels
        for value, text, _ in labels:
            assert float(text.replace(",", "")) == pytest.approx(value)
        # Labels above 100 us wherever the data goes above it.
        if high > 200:
            assert any(value > 100 for value, _, _ in labels)
        # The top labelled tick is within a factor 2.5 of the top of the axis (1-2-5 steps).
        assert max(value for value, _, _ in labels) * 2.5 >= high
        assert not any(
            tick.label1.get_text() for tick in axes.yaxis.get_minor_ticks()
        )  # minor ticks unlabelled
        boxes = sorted((box for _, _, box in labels), key=lambda box: box.y0)
        for lower, upper in itertools.pairwise(boxes):
            assert lower.y1 <= upper.y0, "tick labels overlap"
    finally:
        pyplot.close(figure)
