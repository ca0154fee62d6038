"""The servo budget of §8.2 and §8.4: control time left in each cycle of a read-control-write loop.

The thesis derives it from its transaction times in two ways:

* quadlet-wise, each of the seven axes is read and written on its own:
  7 x (mean quadlet read + mean quadlet write) = 7 x (34.5 + 30.2) = 453 us;
* block-wise, one block read latches every axis and one block write applies
  every command: "about 65 us".

Here the block-wise cycle is the fitted time of the board's real-time
blocks: a 32-quadlet read (4 header quadlets + 4 per channel) and a
7-quadlet write (one DAC quadlet per channel). On the thesis's own fits that
gives 36.0 + 31.5 = 67.5 us, the thesis's "about 65" (its base latencies
alone add to 63.9). What is left of a cycle is the period minus the bus
time; a negative value means the loop does not fit at that rate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fw1394.boards.snake2010.spec import rt_read_quadlets, rt_write_quadlets
from fw1394.experiments import thesis
from fw1394.experiments.fit import LineFit

MICROSECONDS_PER_SECOND = 1e6


def quadlet_loop_us(read_us: float, write_us: float, axes: int = thesis.SERVO_AXES) -> float:
    """One read and one write quadlet per axis."""
    return axes * (read_us + write_us)


def block_loop_us(read: LineFit, write: LineFit, axes: int = thesis.SERVO_AXES) -> float:
    """One real-time block read and one real-time block write for the whole board."""
    return read.at(rt_read_quadlets(axes)) + write.at(rt_write_quadlets(axes))


def left_us(cycle_us: float, rate_hz: float) -> float:
    """Control time left in one period at ``rate_hz`` (negative: the loop does not fit)."""
    return MICROSECONDS_PER_SECOND / rate_hz - cycle_us


@dataclass(frozen=True)
class Budget:
    """Bus time of one cycle and what it leaves at each rate."""

    method: str
    cycle_us: float
    left_us: dict[int, float]

    def as_dict(self) -> dict[str, object]:
        return {
            "method": self.method,
            "cycle_us": round(self.cycle_us, 1),
            "left_us": {str(rate): round(left, 1) for rate, left in self.left_us.items()},
            "feasible": {str(rate): left > 0 for rate, left in self.left_us.items()},
        }


def budget(method: str, cycle_us: float, rates_hz: Sequence[int] = thesis.SERVO_RATES_HZ) -> Budget:
    return Budget(method, cycle_us, {rate: left_us(cycle_us, rate) for rate in rates_hz})
