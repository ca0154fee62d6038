"""Middle layer of the host library: :class:`RobotIO` for one snake board.

Works in blocks as thesis section 7.1 describes: :meth:`Board.latch_all_inputs`
is one block read that fills the local input buffer, and
:meth:`Board.apply_all_outputs` is one fixed-size block write of the motor
commands, with a valid bit per axis, followed by a status write only when
power control was requested. Devices that are not in the real-time blocks
(current limit, encoder preload, digital pot, EEPROM) are reached at once
with quadlet transactions; the docstrings say which is which.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

from fw1394.boards.snake2010.regmap import REGISTER_MAP
from fw1394.boards.snake2010.rt_blocks import (
    RealtimeInputs,
    build_realtime_write,
    parse_realtime_block,
    realtime_read_length,
)
from fw1394.boards.snake2010.spec import (
    ADC_HALF_MASK,
    ADC_POT_SHIFT,
    DAC_MAX,
    DAC_SELECT_CURRENT_LIMIT,
    ENCODER_COUNT_MASK,
    ENCODER_OVERFLOW,
    OUTPUT_O1,
    OUTPUT_O2,
    POT_DATA_MASK,
    POT_DATA_VALID,
    POT_ECHO_MASK,
    POT_READ_COMMANDS,
    REALTIME_OFFSET,
    SNAKE_ACTUATION_CHANNELS,
    STATUS_BOARD_ID_MASK,
    STATUS_BOARD_ID_SHIFT,
    VALID_BIT,
    WIPER_MAX,
    PotCommand,
    pot_frame,
    status_write,
)
from fw1394.errors import Error
from fw1394.host.port import Port
from fw1394.host.robot import RobotIO
from fw1394.host.units import (
    adc_to_unsigned,
    current_feedback_gain,
    float_to_words,
    sign_extend,
    split_eeprom_index,
    words_to_float,
)

#: Offsets come from the board's register map, the one the emulator is checked against.
_STATUS = REGISTER_MAP.offset("STATUS")


class BoardError(Error, RuntimeError):
    """The board answered in a way the library cannot use."""


class Board(RobotIO):
    """One snake-board node as seen through ``port`` at node number ``node``."""

    def __init__(
        self,
        port: Port,
        node: int,
        channels: int = SNAKE_ACTUATION_CHANNELS,
        pot_read_attempts: int = 3,
    ) -> None:
        if not 1 <= channels <= 7:
            raise ValueError(f"a snake board has 1..7 channels, not {channels}")
        self._port = port
        self._node = node
        self._channels = channels
        self._pot_read_attempts = pot_read_attempts
        self._read_length = realtime_read_length(channels)
        self._inputs = RealtimeInputs.empty(channels)
        self._commands: list[int | None] = [None] * channels
        self._power_request: int | None = None

    @property
    def node(self) -> int:
        """Node number the board is addressed by."""
        return self._node

    @property
    def num_axes(self) -> int:
        return self._channels

    @property
    def inputs(self) -> RealtimeInputs:
        """Raw words of the latest real-time block read."""
        return self._inputs

    @property
    def board_id(self) -> int:
        """Rotary-switch number from the latched status (bits 27-24)."""
        return (self._inputs.status >> STATUS_BOARD_ID_SHIFT) & STATUS_BOARD_ID_MASK

    # --- buffer operations --------------------------------------------
    def latch_all_inputs(self) -> None:
        """One real-time block read; every ``get_`` of a latched value uses it."""
        data = self._port.read_block(self._node, REALTIME_OFFSET, self._read_length)
        self._inputs = parse_realtime_block(data, self._channels)

    def apply_all_outputs(self) -> None:
        """Send the buffered motor commands and power request, then clear them.

        The block is written every cycle even if no axis is valid: any write
        transaction feeds the board's watchdog. The power request follows
        the block so amplifiers never switch on under a stale command.
        """
        block = build_realtime_write(self._commands)
        self._port.write_block(self._node, REALTIME_OFFSET, block)
        self._commands = [None] * self._channels
        if self._power_request is not None:
            self._port.write_quadlet(self._node, _STATUS, self._power_request)
            self._power_request = None

    # --- latched reads --------------------------------------------------
    def get_status(self) -> int:
        """Latched status register (Table 2: board id, watchdog, faults, enables)."""
        return self._inputs.status

    def get_timestamp(self) -> int:
        """Latched count of 49.152 MHz clocks since the previous block read."""
        return self._inputs.timestamp

    def get_motor_current(self, axis: int) -> int:
        """Latched motor-current sample: signed 14-bit ADC value + 8192 (0..16383)."""
        return adc_to_unsigned(self._inputs.adc[self._index(axis)] & ADC_HALF_MASK)

    def get_analog_position(self, axis: int) -> int:
        """Latched pot sample: signed 14-bit ADC value + 8192 (0..16383)."""
        return adc_to_unsigned(self._inputs.adc[self._index(axis)] >> ADC_POT_SHIFT)

    def get_encoder_position(self, axis: int) -> int:
        """Latched 24-bit encoder count (preload the mid-point 0x800000 first)."""
        return self._inputs.encoder[self._index(axis)] & ENCODER_COUNT_MASK

    def get_encoder_positions(self) -> list[int]:
        """Every axis's latched 24-bit encoder count, in axis order."""
        return [word & ENCODER_COUNT_MASK for word in self._inputs.encoder]

    def get_encoder_overflow(self, axis: int) -> bool:
        """Latched overflow flag: the count left 0..2**24-1 since the last preload."""
        return bool(self._inputs.encoder[self._index(axis)] & ENCODER_OVERFLOW)

    def get_encoder_velocity(self, axis: int) -> int:
        """Latched signed count of 768 kHz clocks between encoder edges.

        Larger magnitudes mean slower motion; the sign is the direction.
        """
        return sign_extend(self._inputs.period[self._index(axis)], 16)

    # --- immediate reads (pot handshake) -----------------------------------
    def get_digital_pot_wiper(self, axis: int) -> int:
        """Wiper position 0..1023, read at once through the pot handshake."""
        return self._pot_read(axis, PotCommand.READ_WIPER)

    def get_feedback_gain(self, axis: int) -> float:
        """Current-feedback gain of ``axis`` from its wiper, thesis equation (1)."""
        return current_feedback_gain(self.get_digital_pot_wiper(axis))

    def get_analog_switches(self, axis: int) -> int:
        """Pot outputs read at once: bit 0 = O1 (1 speed, 0 torque control), bit 1 = O2."""
        return self._pot_read(axis, PotCommand.READ_OUTPUTS)

    def get_eeprom_data_raw(self, index: int) -> int:
        """EEPROM word read at once; ``index`` = axis << 4 | word (word 0..13)."""
        axis, word = split_eeprom_index(index)
        return self._pot_read(axis, PotCommand.READ_EEPROM, word)

    def get_eeprom_data_float(self, index: int) -> float:
        """Float kept in words ``index`` (high half) and ``index + 1`` (low half)."""
        split_eeprom_index(index + 1)  # both words must exist
        return words_to_float(self.get_eeprom_data_raw(index), self.get_eeprom_data_raw(index + 1))

    # --- buffered writes ------------------------------------------------------
    def set_power_control(self, value: int) -> None:
        """Buffer a status-register write (enable mask << 8 | enables).

        Only amplifiers whose mask bit is set change; sent by
        :meth:`apply_all_outputs`.
        """
        if not 0 <= value <= 0xFFFF:
            raise ValueError(f"power control {value:#x} is not mask << 8 | enables")
        self._power_request = value

    def power_word(self, axes: Iterable[int], on: bool) -> int:
        mask = 0
        for axis in axes:
            mask |= 1 << self._index(axis)
        return status_write(mask, mask if on else 0)

    def set_motor_voltage(self, axis: int, value: int) -> None:
        """Buffer a motor command: DAC code 0..65535, 0x8000 (1.25 V) = stop.

        Codes above the mid-point turn the motor one way, below it the
        other; the speed grows with the distance from 0x8000.
        """
        self._commands[self._index(axis)] = _checked(value, DAC_MAX, "DAC code")

    def set_motor_voltages(self, values: Sequence[int]) -> None:
        """Buffer every axis's motor command at once (DAC codes, as :meth:`set_motor_voltage`)."""
        self._one_per_axis(values)
        commands: list[int | None] = list(values)
        # One range check for the block; the first bad code names itself.
        if min(values) < 0 or max(values) > DAC_MAX:
            commands = [_checked(value, DAC_MAX, "DAC code") for value in values]
        self._commands = commands

    # --- immediate writes ---------------------------------------------------
    def set_motor_current(self, axis: int, value: int) -> None:
        """Write the current-limit DAC (code 0..65535, 0..2.5 V) at once.

        The limit shares the dual DAC with the motor command and cannot go
        in the same transaction, so it is its own quadlet write.
        """
        code = _checked(value, DAC_MAX, "DAC code")
        register = self._register(axis, "DAC")
        self._port.write_quadlet(self._node, register, VALID_BIT | DAC_SELECT_CURRENT_LIMIT | code)

    def set_encoder_preload(self, axis: int, value: int) -> None:
        """Load the 24-bit encoder counter at once (clears its overflow flag)."""
        count = _checked(value, ENCODER_COUNT_MASK, "encoder preload")
        self._port.write_quadlet(self._node, self._register(axis, "ENCODER_PRELOAD"), count)

    def set_digital_pot_wiper(self, axis: int, value: int) -> None:
        """Set the wiper 0..1023 at once; the feedback gain follows equation (1)."""
        self._pot_write(axis, PotCommand.WRITE_WIPER, 0, _checked(value, WIPER_MAX, "wiper"))

    def set_analog_switches(self, axis: int, value: int) -> None:
        """Set the pot outputs at once: bit 0 = O1 (1 speed, 0 torque), bit 1 = O2."""
        outputs = _checked(value, OUTPUT_O1 | OUTPUT_O2, "switch bits")
        self._pot_write(axis, PotCommand.WRITE_OUTPUTS, 0, outputs)

    def set_eeprom_data_raw(self, index: int, value: int) -> None:
        """Store a 16-bit EEPROM word at once; ``index`` = axis << 4 | word."""
        axis, word = split_eeprom_index(index)
        self._pot_write(axis, PotCommand.WRITE_EEPROM, word, _checked(value, 0xFFFF, "word"))

    def set_eeprom_data_float(self, index: int, value: float) -> None:
        """Store a float as two words: high half at ``index``, low at ``index + 1``."""
        split_eeprom_index(index + 1)
        high, low = float_to_words(value)
        self.set_eeprom_data_raw(index, high)
        self.set_eeprom_data_raw(index + 1, low)

    # --- helpers --------------------------------------------------------------
    def _index(self, axis: int) -> int:
        if not 0 <= axis < self._channels:
            raise IndexError(f"axis {axis} outside 0..{self._channels - 1}")
        return axis

    def _register(self, axis: int, name: str) -> int:
        return REGISTER_MAP.offset(name, self._index(axis) + 1)

    def _pot_write(self, axis: int, command: PotCommand, address: int, data: int) -> None:
        register = self._register(axis, "POT_CONTROL")
        self._port.write_quadlet(self._node, register, pot_frame(command, address, data))

    def _pot_read(self, axis: int, command: PotCommand, address: int = 0) -> int:
        # Thesis 6.2: a write asks the FPGA to fetch the value from the pot,
        # a second transaction collects it from the pot data register.
        assert command in POT_READ_COMMANDS
        self._pot_write(axis, command, address, 0)
        expected = pot_frame(command, address) & POT_ECHO_MASK
        register = self._register(axis, "POT_DATA")
        for _ in range(self._pot_read_attempts):
            word = self._port.read_quadlet(self._node, register)
            if word & POT_DATA_VALID and word & POT_ECHO_MASK == expected:
                return word & POT_DATA_MASK
        raise BoardError(f"node {self._node} axis {axis}: no answer to pot {command.name}")


def _checked(value: int, highest: int, what: str) -> int:
    if not 0 <= value <= highest:
        raise ValueError(f"{what} {value} outside 0..{highest}")
    return value
