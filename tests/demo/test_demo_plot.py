"""The demo's figure: commanded and measured apart at a glance, and the tracking error."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import pytest
from matplotlib.colors import to_rgb

from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.demo.report import (
    COMMANDED_LABEL,
    ERROR_TITLE,
    MEASURED_LABEL,
    axis_title,
    figure_of,
    plot,
)
from fw1394.demo.run import DemoResult

AXES = 11


def lagging_result(lag_s: float = 0.03) -> DemoResult:
    """Sine commands, and positions that follow them ``lag_s`` late."""
    result = DemoResult(cycles=400, seconds=2.0)
    for i in range(400):
        t = i / 200
        result.times.append(t)
        result.commanded.append(
            [ENCODER_MIDPOINT + 1500 * math.sin(math.pi * t + a) for a in range(AXES)]
        )
        result.measured.append(
            [
                round(ENCODER_MIDPOINT + 1500 * math.sin(math.pi * (t - lag_s) + a))
                for a in range(AXES)
            ]
        )
    return result


def luminance(colour: object) -> float:
    red, green, blue = to_rgb(colour)  # type: ignore[arg-type]
    return 0.2126 * red + 0.7152 * green + 0.0722 * blue


def test_commanded_and_measured_differ_in_hue_and_lightness() -> None:
    result = lagging_result()
    figure = figure_of(result)
    try:
        panels = [a for a in figure.axes if a.get_title().startswith("axis ")]
        assert [p.get_title() for p in panels] == [axis_title(a) for a in range(AXES)]
        for panel in panels:
            lines = {line.get_label(): line for line in panel.get_lines()}
            commanded, measured = lines[COMMANDED_LABEL], lines[MEASURED_LABEL]
            distance = math.dist(to_rgb(commanded.get_color()), to_rgb(measured.get_color()))
            assert distance > 0.5
            # Still apart when printed in grey.
            assert abs(luminance(commanded.get_color()) - luminance(measured.get_color())) > 0.2
            assert commanded.get_linestyle() != measured.get_linestyle()
    finally:
        plt.close(figure)


def test_tracking_error_panel_shows_commanded_minus_measured() -> None:
    result = lagging_result()
    figure = figure_of(result)
    try:
        (panel,) = [a for a in figure.axes if a.get_title() == ERROR_TITLE]
        curves = [line for line in panel.get_lines() if not str(line.get_label()).startswith("_")]
        by_axis = {line.get_label(): line for line in curves}
        for axis in range(AXES):
            drawn = list(by_axis[str(axis + 1)].get_ydata())
            pairs = zip(result.commanded, result.measured, strict=True)
            assert drawn == pytest.approx([c[axis] - m[axis] for c, m in pairs])
        # A 30 ms lag on a 0.5 Hz, 1500-count sine: errors up to about 1500 * pi * 0.03.
        peak = max(abs(v) for line in curves for v in line.get_ydata())
        assert 100 < peak < 1500 * math.pi * 0.03 + 2
    finally:
        plt.close(figure)


def test_plot_writes_a_png(tmp_path: Path) -> None:
    path = tmp_path / "demo.png"
    plot(lagging_result(), path)
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
