"""A small PD position servo over any :class:`RobotIO`.

Each :meth:`PositionLoop.step` is one servo cycle in the thesis's
read-control-write pattern: latch every input (one block read per node),
compute a command per axis, apply every output (one block write per node).
Positions are encoder counts; commands are DAC codes around the mid-point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from fw1394.host.robot import RobotIO
from fw1394.host.units import count_difference, dac_code

#: Target position (encoder counts) as a function of loop time (seconds).
Trajectory = Callable[[float], float]

#: Largest command offset: the whole DAC range on either side of 0x8000.
FULL_SCALE_COMMAND = 0x7FFF


@dataclass(frozen=True)
class PdGains:
    """Gains of one axis, in DAC codes per count and per count/s."""

    kp: float
    kd: float = 0.0
    max_command: int = FULL_SCALE_COMMAND


class PositionLoop:
    """Servo ``io``'s axes onto ``trajectories`` at ``rate_hz``.

    Velocity comes from the encoder difference over the nominal period,
    which keeps the loop independent of how many nodes the robot spans.
    The loop does not switch amplifiers on; the caller decides that.
    """

    def __init__(
        self,
        io: RobotIO,
        trajectories: Sequence[Trajectory],
        gains: PdGains | Sequence[PdGains],
        rate_hz: float = 1000.0,
    ) -> None:
        if len(trajectories) != io.num_axes:
            raise ValueError(f"{len(trajectories)} trajectories for {io.num_axes} axes")
        per_axis = [gains] * io.num_axes if isinstance(gains, PdGains) else list(gains)
        if len(per_axis) != io.num_axes:
            raise ValueError(f"{len(per_axis)} gain sets for {io.num_axes} axes")
        if rate_hz <= 0:
            raise ValueError("rate_hz must be positive")
        self.io = io
        self.trajectories = tuple(trajectories)
        self.gains = tuple(per_axis)
        self.rate_hz = rate_hz
        self.cycle = 0
        self.errors: list[float] = [0.0] * io.num_axes
        self._previous: list[int] | None = None

    @property
    def time(self) -> float:
        """Loop time of the next cycle, in seconds."""
        return self.cycle / self.rate_hz

    def step(self) -> list[float]:
        """Run one servo cycle; return each axis's position error (counts)."""
        io, t = self.io, self.time
        io.latch_all_inputs()
        positions = io.get_encoder_positions()
        previous = self._previous or positions
        commands = []
        for axis, position in enumerate(positions):
            gains = self.gains[axis]
            # The counter wraps at 24 bits; compare positions through that.
            error = count_difference(round(self.trajectories[axis](t)), position)
            velocity = count_difference(position, previous[axis]) * self.rate_hz
            command = gains.kp * error - gains.kd * velocity
            limit = gains.max_command
            commands.append(dac_code(round(min(max(command, -limit), limit))))
            self.errors[axis] = error
        io.set_motor_voltages(commands)
        io.apply_all_outputs()
        self._previous = positions
        self.cycle += 1
        return list(self.errors)
