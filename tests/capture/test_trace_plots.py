"""The latency histogram of ``dissect --plot-latency``: percentiles, off-scale note, count axis."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from fw1394.capture.views.trace_plots import format_us, latency_figure, require_matplotlib

pyplot = require_matplotlib()


def figure_for(latency_us: np.ndarray) -> Any:
    figure = latency_figure(pyplot, latency_us, len(latency_us), "trace")
    figure.canvas.draw()  # tick labels exist once drawn
    return figure


def texts(axes: Any) -> list[str]:
    return [text.get_text() for text in axes.texts]


def test_outliers_are_counted_in_a_note_and_percentiles_marked() -> None:
    rng = np.random.default_rng(7)
    typical = rng.gamma(4.0, 5.0, 5000)
    stragglers = np.array([2_500.0, 9_000.0, 25_000.0])
    latency = np.concatenate([typical, stragglers])
    figure = figure_for(latency)
    try:
        (axes,) = figure.axes
        (note,) = texts(axes)
        assert note == f"3 off scale: {format_us(2500.0)} to {format_us(25000.0)}"
        assert note == "3 off scale: 2.5 ms to 25 ms"
        drawn = sum(patch.get_height() for patch in axes.patches)
        assert drawn == len(typical)  # every transaction is either drawn or in the note
        markers = {line.get_label(): line.get_xdata()[0] for line in axes.get_lines()}
        p50, p99 = np.percentile(latency, [50, 99])
        assert markers == {f"p50 {format_us(p50)}": p50, f"p99 {format_us(p99)}": p99}
        legend = [text.get_text() for text in axes.get_legend().get_texts()]
        assert legend == list(markers)
    finally:
        pyplot.close(figure)


def test_a_single_straggler_is_named_once() -> None:
    latency = np.concatenate([np.random.default_rng(4).normal(20.0, 2.0, 500), [30_600.0]])
    figure = figure_for(latency)
    try:
        assert texts(figure.axes[0]) == ["1 off scale: 30.6 ms"]
    finally:
        pyplot.close(figure)


def test_no_note_when_everything_fits() -> None:
    latency = np.random.default_rng(3).normal(20.0, 2.0, 2000)
    figure = figure_for(latency)
    try:
        (axes,) = figure.axes
        assert texts(axes) == []
        assert sum(patch.get_height() for patch in axes.patches) == len(latency)
    finally:
        pyplot.close(figure)


@pytest.mark.parametrize("count", [1, 3, 7])
def test_small_traces_count_in_whole_transactions(count: int) -> None:
    figure = figure_for(np.linspace(10.0, 40.0, count))
    try:
        (axes,) = figure.axes
        labels = [label.get_text().replace("\u2212", "-") for label in axes.get_yticklabels()]
        visible = [float(text) for text in labels if text]
        assert visible and all(value == int(value) for value in visible), labels
    finally:
        pyplot.close(figure)


def test_an_empty_trace_still_draws() -> None:
    figure = figure_for(np.zeros(0))
    try:
        assert figure.axes[0].get_title() == "trace: 0 transactions"
    finally:
        pyplot.close(figure)
