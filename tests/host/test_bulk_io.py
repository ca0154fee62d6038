"""The whole-robot calls equal their per-axis forms, and the board's registers.

``get_encoder_positions`` must give what each axis's ``get_encoder_position``
gives, which is the encoder register a quadlet read returns; after
``set_motor_voltages`` and ``apply_all_outputs`` the boards' DAC registers must
hold what the per-axis ``set_motor_voltage`` calls would have put there.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.regmap import REGISTER_MAP
from fw1394.boards.snake2010.spec import DAC_CODE_MASK, ENCODER_COUNT_MASK
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host import Board, LocalPort, ManualClock, MultiBoard

AXES = (7, 4)


def _robot() -> tuple[MultiBoard, dict[int, Snake2010Board], ManualClock]:
    clock = ManualClock()
    spaces = {n: Snake2010Board(board_id=n, channels=c) for n, c in enumerate(AXES)}
    port = LocalPort(spaces, clock)
    robot = MultiBoard([Board(port, n, c) for n, c in enumerate(AXES)])
    robot.set_power_control(robot.power_word(range(robot.num_axes), on=True))
    robot.apply_all_outputs()
    return robot, spaces, clock


def _register(space: Snake2010Board, name: str, channel: int) -> int:
    return space.read_quadlet(REGISTER_MAP.offset(name, channel))


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(st.lists(st.integers(0, 0xFFFF), min_size=11, max_size=11), st.integers(1, 5)),
        min_size=1,
        max_size=5,
    )
)
def test_bulk_calls_equal_the_per_axis_calls_and_the_registers(
    script: list[tuple[list[int], int]],
) -> None:
    robot, spaces, clock = _robot()
    for commands, milliseconds in script:
        robot.set_motor_voltages(commands)
        robot.apply_all_outputs()
        clock.advance(milliseconds * TICKS_PER_SECOND // 1000)
        robot.latch_all_inputs()
        positions = robot.get_encoder_positions()
        assert positions == [robot.get_encoder_position(a) for a in range(robot.num_axes)]
        for axis, position in enumerate(positions):
            board, local = robot.locate(axis)
            space = spaces[board.node]
            assert position == _register(space, "ENCODER_DATA", local + 1) & ENCODER_COUNT_MASK
            dac = _register(space, "DAC", local + 1)
            assert dac & DAC_CODE_MASK == commands[axis]


def test_bulk_writes_check_like_the_per_axis_ones() -> None:
    robot, _, _ = _robot()
    with pytest.raises(ValueError, match="10 motor commands for 11 axes"):
        robot.set_motor_voltages([0x8000] * 10)
    with pytest.raises(ValueError, match="DAC code"):
        robot.set_motor_voltages([0x8000] * 10 + [0x10000])
    with pytest.raises(ValueError, match="DAC code -1 outside"):
        robot.set_motor_voltages([-1] + [0x8000] * 10)
