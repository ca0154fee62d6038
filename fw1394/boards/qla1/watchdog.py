"""The board watchdog, counted in 49.152 MHz ticks.

The firmware counts a clock of sysclk / 256 (5.208 us). Any register write
clears the count; while the period register is non-zero the count climbs to
the period, and the *next* divided-clock edge raises the timeout flag, which
stays up until the host asks for power or an amplifier. This edge-exact
behaviour comes from reading the Verilog (BoardRegs.v), not from a
simulation. The divided clock is free-running, so its edges fall on the
multiples of 256 ticks since power-up.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.boards.qla1.regs import (
    WATCHDOG_DEFAULT_PERIOD,
    WATCHDOG_LED_MODE,
    WATCHDOG_PERIOD_MASK,
    WATCHDOG_TICKS_PER_COUNT,
)


@dataclass
class Watchdog:
    """Period register, count and timeout flag."""

    period: int = WATCHDOG_DEFAULT_PERIOD
    led_mode: bool = False
    timed_out: bool = False
    last_clear_tick: int = 0

    def register_value(self) -> int:
        return (WATCHDOG_LED_MODE if self.led_mode else 0) | self.period

    def write_register(self, value: int) -> None:
        self.period = value & WATCHDOG_PERIOD_MASK
        self.led_mode = bool(value & WATCHDOG_LED_MODE)

    def clear_count(self, now: int) -> None:
        """Any register write restarts the count (the flag stays)."""
        self.last_clear_tick = now

    def acknowledge(self, now: int) -> None:
        """A power or amplifier enable request clears both count and flag."""
        self.timed_out = False
        self.last_clear_tick = now

    def edges_since_clear(self, now: int) -> int:
        return now // WATCHDOG_TICKS_PER_COUNT - self.last_clear_tick // WATCHDOG_TICKS_PER_COUNT

    def advance(self, now: int) -> bool:
        """Bring the flag up to date at tick ``now``; True when it has just been raised."""
        if self.timed_out or self.period == 0:
            return False
        if self.edges_since_clear(now) > self.period:
            self.timed_out = True
            return True
        return False
