"""One :class:`RobotIO` over several nodes (a snake robot needs two: 7 + 4).

Axes are numbered across the boards in order: the first board's axes come
first. Whole-robot words are the per-board words side by side, board ``k``
in bits ``32k .. 32k+31``: :meth:`MultiBoard.get_status`,
:meth:`MultiBoard.get_timestamp` and :meth:`MultiBoard.set_power_control`
(where a zero part leaves that board alone). EEPROM indices name the robot
axis in bits 7-4, as on one board.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from fw1394.host.board import Board
from fw1394.host.robot import RobotIO
from fw1394.host.units import eeprom_index, split_eeprom_index

WORD_BITS = 32
WORD_MASK = 0xFFFF_FFFF


class MultiBoard(RobotIO):
    """Robot I/O spread over ``boards``; one block read and write per node."""

    def __init__(self, boards: Sequence[Board]) -> None:
        if not boards:
            raise ValueError("a robot needs at least one board")
        self.boards = tuple(boards)
        self._axes = [(board, axis) for board in self.boards for axis in range(board.num_axes)]

    @property
    def num_axes(self) -> int:
        return len(self._axes)

    def locate(self, axis: int) -> tuple[Board, int]:
        """The board carrying robot ``axis`` and the axis number on that board."""
        if not 0 <= axis < len(self._axes):
            raise IndexError(f"axis {axis} outside 0..{len(self._axes) - 1}")
        return self._axes[axis]

    def latch_all_inputs(self) -> None:
        for board in self.boards:
            board.latch_all_inputs()

    def apply_all_outputs(self) -> None:
        for board in self.boards:
            board.apply_all_outputs()

    def get_status(self) -> int:
        return _side_by_side(board.get_status() for board in self.boards)

    def get_timestamp(self) -> int:
        return _side_by_side(board.get_timestamp() for board in self.boards)

    def get_motor_current(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_motor_current(local)

    def get_analog_position(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_analog_position(local)

    def get_encoder_position(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_encoder_position(local)

    def get_encoder_positions(self) -> list[int]:
        return [count for board in self.boards for count in board.get_encoder_positions()]

    def get_encoder_velocity(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_encoder_velocity(local)

    def get_digital_pot_wiper(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_digital_pot_wiper(local)

    def get_analog_switches(self, axis: int) -> int:
        board, local = self.locate(axis)
        return board.get_analog_switches(local)

    def get_eeprom_data_raw(self, index: int) -> int:
        board, local_index = self._eeprom(index)
        return board.get_eeprom_data_raw(local_index)

    def get_eeprom_data_float(self, index: int) -> float:
        board, local_index = self._eeprom(index)
        return board.get_eeprom_data_float(local_index)

    def set_power_control(self, value: int) -> None:
        for k, board in enumerate(self.boards):
            part = (value >> (WORD_BITS * k)) & WORD_MASK
            if part:
                board.set_power_control(part)

    def power_word(self, axes: Iterable[int], on: bool) -> int:
        per_board: dict[int, list[int]] = {}
        for axis in axes:
            board, local = self.locate(axis)
            per_board.setdefault(self.boards.index(board), []).append(local)
        word = 0
        for k, local_axes in per_board.items():
            word |= self.boards[k].power_word(local_axes, on) << (WORD_BITS * k)
        return word

    def set_motor_voltage(self, axis: int, value: int) -> None:
        board, local = self.locate(axis)
        board.set_motor_voltage(local, value)

    def set_motor_voltages(self, values: Sequence[int]) -> None:
        self._one_per_axis(values)
        first = 0
        for board in self.boards:
            board.set_motor_voltages(values[first : first + board.num_axes])
            first += board.num_axes

    def set_motor_current(self, axis: int, value: int) -> None:
        board, local = self.locate(axis)
        board.set_motor_current(local, value)

    def set_encoder_preload(self, axis: int, value: int) -> None:
        board, local = self.locate(axis)
        board.set_encoder_preload(local, value)

    def set_digital_pot_wiper(self, axis: int, value: int) -> None:
        board, local = self.locate(axis)
        board.set_digital_pot_wiper(local, value)

    def set_analog_switches(self, axis: int, value: int) -> None:
        board, local = self.locate(axis)
        board.set_analog_switches(local, value)

    def set_eeprom_data_raw(self, index: int, value: int) -> None:
        board, local_index = self._eeprom(index)
        board.set_eeprom_data_raw(local_index, value)

    def set_eeprom_data_float(self, index: int, value: float) -> None:
        board, local_index = self._eeprom(index)
        board.set_eeprom_data_float(local_index, value)

    def _eeprom(self, index: int) -> tuple[Board, int]:
        axis, word = split_eeprom_index(index)
        board, local = self.locate(axis)
        return board, eeprom_index(local, word)


def _side_by_side(words: Iterable[int]) -> int:
    combined = 0
    for k, word in enumerate(words):
        combined |= (word & WORD_MASK) << (WORD_BITS * k)
    return combined
