"""Top layer of the host library: abstract robot I/O (thesis section 7.1).

Control code talks to this interface only, one axis at a time, with plain
integers; :meth:`RobotIO.latch_all_inputs` samples every sensor at once and
:meth:`RobotIO.apply_all_outputs` sends every buffered output at once,
matching hardware with simultaneously sampled inputs and double-buffered
outputs. Axes are numbered from 0. The method names are the Python forms of
the calls listed in section 7.2 (``GetMotorCurrent`` -> ``get_motor_current``
and so on); failures raise exceptions instead of returning ``false``.

Which calls act on the latched/buffered data and which talk to the hardware
at once is up to the implementation; :class:`fw1394.host.board.Board`
documents its choice per method.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from collections.abc import Iterable, Sequence


class RobotIO(ABC):
    """Per-axis sensor reads and actuator writes for one robot."""

    @property
    @abstractmethod
    def num_axes(self) -> int:
        """Number of axes, numbered 0..num_axes-1."""

    # --- buffer operations ----------------------------------------------
    @abstractmethod
    def latch_all_inputs(self) -> None:
        """Sample every input of every axis into the local buffers."""

    @abstractmethod
    def apply_all_outputs(self) -> None:
        """Send every buffered output to the hardware."""

    # --- reads ------------------------------------------------------------
    @abstractmethod
    def get_status(self) -> int:
        """Hardware status word, all axes combined (power, faults, watchdog)."""

    @abstractmethod
    def get_timestamp(self) -> int:
        """Clock ticks between the two latest :meth:`latch_all_inputs` calls."""

    @abstractmethod
    def get_motor_current(self, axis: int) -> int:
        """Motor-current sample of ``axis``."""

    @abstractmethod
    def get_analog_position(self, axis: int) -> int:
        """Potentiometer (absolute position) sample of ``axis``."""

    @abstractmethod
    def get_encoder_position(self, axis: int) -> int:
        """Incremental encoder count of ``axis``."""

    def get_encoder_positions(self) -> list[int]:
        """:meth:`get_encoder_position` of every axis, in axis order.

        One call for a servo loop's whole read side; implementations serve it
        from the latched block without a call per axis.
        """
        return [self.get_encoder_position(axis) for axis in range(self.num_axes)]

    @abstractmethod
    def get_encoder_velocity(self, axis: int) -> int:
        """Encoder velocity measure of ``axis`` (signed)."""

    @abstractmethod
    def get_digital_pot_wiper(self, axis: int) -> int:
        """Current-feedback gain setting of ``axis``."""

    @abstractmethod
    def get_analog_switches(self, axis: int) -> int:
        """Mode switches of ``axis`` (speed or torque control)."""

    @abstractmethod
    def get_eeprom_data_raw(self, index: int) -> int:
        """One non-volatile word; ``index`` names the axis and the word."""

    @abstractmethod
    def get_eeprom_data_float(self, index: int) -> float:
        """A float kept in the non-volatile words at ``index`` and ``index + 1``."""

    # --- writes -------------------------------------------------------------
    @abstractmethod
    def set_power_control(self, value: int) -> None:
        """Switch amplifiers on or off, all axes combined."""

    @abstractmethod
    def power_word(self, axes: Iterable[int], on: bool) -> int:
        """The :meth:`set_power_control` value switching only ``axes`` to ``on``."""

    @abstractmethod
    def set_motor_voltage(self, axis: int, value: int) -> None:
        """Motor command of ``axis``."""

    def set_motor_voltages(self, values: Sequence[int]) -> None:
        """:meth:`set_motor_voltage` of every axis: ``values[axis]`` for each axis."""
        self._one_per_axis(values)
        for axis, value in enumerate(values):
            self.set_motor_voltage(axis, value)

    def _one_per_axis(self, values: Sequence[int]) -> None:
        if len(values) != self.num_axes:
            raise ValueError(f"{len(values)} motor commands for {self.num_axes} axes")

    @abstractmethod
    def set_motor_current(self, axis: int, value: int) -> None:
        """Motor current limit of ``axis``."""

    @abstractmethod
    def set_encoder_preload(self, axis: int, value: int) -> None:
        """Load the encoder counter of ``axis``."""

    @abstractmethod
    def set_digital_pot_wiper(self, axis: int, value: int) -> None:
        """Current-feedback gain setting of ``axis``."""

    @abstractmethod
    def set_analog_switches(self, axis: int, value: int) -> None:
        """Mode switches of ``axis``."""

    @abstractmethod
    def set_eeprom_data_raw(self, index: int, value: int) -> None:
        """Store one non-volatile word."""

    @abstractmethod
    def set_eeprom_data_float(self, index: int, value: float) -> None:
        """Store a float in the words at ``index`` and ``index + 1``."""
