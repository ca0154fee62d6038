"""The demo's targets are the formula its docstring states, bit for bit."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.demo.run import trajectory


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 10), st.floats(0.0, 1.0) | st.floats(0.0, 1e4))
def test_demo_trajectory_is_its_formula(axis: int, t: float) -> None:
    # A sine of the axis's own amplitude, frequency and phase, ramped in over 0.5 s.
    amplitude = 1500.0 * (1 + axis % 4)
    expected = ENCODER_MIDPOINT + min(t / 0.5, 1.0) * amplitude * math.sin(
        2 * math.pi * (0.5 + 0.15 * axis) * t + axis * 0.7
    )
    assert trajectory(axis)(t) == expected
