"""A small PD position servo over any :class:`RobotIO`.

Each :meth:`PositionLoop.step` is one servo cycle in the thesis's
read-control-write pattern: latch every input (one block read per node),
compute a command per axis, apply every output (one block write per node).
Positions are encoder counts; commands are DAC codes around the mid-point.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

from fw1394.boards.snake2010.spec import DAC_MAX, DAC_MIDPOINT, ENCODER_BITS
from fw1394.host.robot import RobotIO

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
        self._trajectories = tuple(trajectories)
        self._gains = tuple(per_axis)
        # Per axis, what the law needs and nothing else: one tuple to unpack per axis.
        self._laws = tuple(
            (trajectory, gain.kp, gain.kd, gain.max_command)
            for trajectory, gain in zip(self._trajectories, self._gains, strict=True)
        )
        self.rate_hz = rate_hz
        self.cycle = 0
        self.errors: list[float] = [0.0] * io.num_axes
        self._previous: list[int] | None = None

    @property
    def trajectories(self) -> tuple[Trajectory, ...]:
        """Each axis's target position over loop time."""
        return self._trajectories

    @property
    def gains(self) -> tuple[PdGains, ...]:
        """Each axis's gains."""
        return self._gains

    @property
    def time(self) -> float:
        """Loop time of the next cycle, in seconds."""
        return self.cycle / self.rate_hz

    def step(self) -> list[float]:
        """Run one servo cycle; return each axis's position error (counts).

        The law is :func:`fw1394.host.units.count_difference` and
        :func:`~fw1394.host.units.dac_code` written out inline: it runs for every
        axis of every cycle between the read of the last board and the first write.
        """
        io, t, rate = self.io, self.time, self.rate_hz
        io.latch_all_inputs()
        positions = io.get_encoder_positions()
        previous = self._previous or positions
        errors: list[float] = []
        commands = []
        for (target, kp, kd, limit), position, before in zip(
            self._laws, positions, previous, strict=True
        ):
            # The counter wraps at 24 bits; compare positions through that.
            error = ((round(target(t)) - position + _HALF_COUNT) & _COUNT_MASK) - _HALF_COUNT
            velocity = (((position - before + _HALF_COUNT) & _COUNT_MASK) - _HALF_COUNT) * rate
            command = kp * error - kd * velocity
            code = DAC_MIDPOINT + round(min(max(command, -limit), limit))
            commands.append(0 if code < 0 else DAC_MAX if code > DAC_MAX else code)
            errors.append(error)
        io.set_motor_voltages(commands)
        io.apply_all_outputs()
        self._previous = positions
        self.errors = errors
        self.cycle += 1
        return list(errors)


_COUNT_MASK = (1 << ENCODER_BITS) - 1
_HALF_COUNT = 1 << (ENCODER_BITS - 1)
