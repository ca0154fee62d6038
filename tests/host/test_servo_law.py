"""``PositionLoop.step``'s inline law equals the PD law written with the unit helpers.

The reference below is the law as the host library states it: the error and the
velocity through :func:`count_difference` (24-bit wrap-around), the command
clipped to the axis's limit, rounded, and turned into a DAC code by
:func:`dac_code`. The loop runs on boards whose real-time blocks carry scripted
encoder words, so every count, wrap and clip a cycle can meet is reachable; the
commands are read back from the block writes the boards send.
"""

from __future__ import annotations

import struct

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.spec import (
    DAC_CODE_MASK,
    ENCODER_COUNT_MASK,
    VALID_BIT,
    rt_encoder_index,
)
from fw1394.host import Board, MultiBoard, PdGains, PositionLoop, Trajectory
from fw1394.host.units import count_difference, dac_code

AXES = (7, 4)
RATE_HZ = 1000.0


class ScriptedPort:
    """Real-time blocks with the encoder words of the current cycle; writes recorded."""

    def __init__(self) -> None:
        self.encoders: dict[int, list[int]] = {}
        self.writes: dict[int, bytes] = {}

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        channels = AXES[node]
        words = [0] * (length // 4)
        for channel, word in enumerate(self.encoders[node], start=1):
            words[rt_encoder_index(channel, channels)] = word
        return struct.pack(f">{len(words)}I", *words)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self.writes[node] = data

    def read_quadlet(self, node: int, offset: int) -> int:
        raise AssertionError("the servo loop reads blocks only")

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        raise AssertionError("the servo loop writes blocks only")


def reference_step(
    targets: list[float], positions: list[int], previous: list[int], gains: list[PdGains]
) -> tuple[list[int], list[int]]:
    """The DAC codes and errors of one cycle, per axis, with the unit helpers."""
    codes, errors = [], []
    for target, position, before, gain in zip(targets, positions, previous, gains, strict=True):
        error = count_difference(round(target), position)
        velocity = count_difference(position, before) * RATE_HZ
        command = gain.kp * error - gain.kd * velocity
        limit = gain.max_command
        codes.append(dac_code(round(min(max(command, -limit), limit))))
        errors.append(error)
    return codes, errors


gains_strategy = st.builds(
    PdGains,
    kp=st.floats(-50.0, 50.0, allow_nan=False),
    kd=st.floats(-1.0, 1.0, allow_nan=False),
    max_command=st.integers(0, 0x2_0000),  # limits past the DAC's half range too
)
encoder_word = st.integers(0, 0xFFFF_FFFF)  # the overflow flag and bits above the count too


@settings(max_examples=200, deadline=None)
@given(
    st.lists(gains_strategy, min_size=11, max_size=11),
    st.lists(
        st.tuples(
            st.lists(encoder_word, min_size=11, max_size=11),
            st.lists(st.floats(-2.0**25, 2.0**25, allow_nan=False), min_size=11, max_size=11),
        ),
        min_size=1,
        max_size=4,
    ),
)
def test_step_equals_the_reference_law(
    gains: list[PdGains], cycles: list[tuple[list[int], list[float]]]
) -> None:
    port = ScriptedPort()
    robot = MultiBoard([Board(port, node, axes) for node, axes in enumerate(AXES)])
    targets_now = [0.0] * robot.num_axes

    def follow(axis: int) -> Trajectory:
        return lambda t: targets_now[axis]

    loop = PositionLoop(robot, [follow(a) for a in range(robot.num_axes)], gains, RATE_HZ)
    previous: list[int] | None = None
    for words, targets in cycles:
        port.encoders = {0: words[:7], 1: words[7:]}
        targets_now[:] = targets
        errors = loop.step()
        positions = [word & ENCODER_COUNT_MASK for word in words]
        codes, expected_errors = reference_step(targets, positions, previous or positions, gains)
        written = [
            word
            for node in range(len(AXES))
            for word in struct.unpack(f">{AXES[node]}I", port.writes[node])
        ]
        assert all(word & VALID_BIT for word in written)
        assert [word & DAC_CODE_MASK for word in written] == codes
        assert errors == expected_errors == loop.errors
        previous = positions
