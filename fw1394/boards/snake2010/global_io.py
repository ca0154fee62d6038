"""Global I/O pieces of the snake board: the watchdog and the PHY window.

Thesis section 6.3. The watchdog counter advances once every 256 clocks of
the 49.152 MHz system clock (5.2083 us) from a free-running prescaler, is
cleared by every write transaction, and times out when it reaches the
16-bit period; a period of 0 (the power-up value) disables it.

The PHY control/data registers give the host access to the registers of
the TSB41AB2 physical-layer chip; the thesis only names them, so their
formats and the PHY register contents below are invented (an IEEE 1394a
PHY's base registers, two ports, S400).
"""

from __future__ import annotations

from fw1394.boards.snake2010.spec import (
    PHY_ADDRESS_MASK,
    PHY_ADDRESS_SHIFT,
    PHY_VALUE_MASK,
    PHY_WRITE_REQUEST,
    WATCHDOG_PERIOD_MASK,
    WATCHDOG_PRESCALER,
)
from fw1394.packets.nodeid import BROADCAST_PHY


class Watchdog:
    """Period register, counter and timeout condition, in absolute ticks."""

    def __init__(self) -> None:
        self.period = 0  # disabled
        self._cleared_at = 0
        self._expired = False

    def feed(self, now: int) -> None:
        """A write transaction arrived at tick ``now``: clear the counter."""
        self._cleared_at = now
        self._expired = False

    def counter(self, now: int) -> int:
        """Counter value at ``now``: prescaler edges since the last clear."""
        edges = now // WATCHDOG_PRESCALER - self._cleared_at // WATCHDOG_PRESCALER
        return min(edges, WATCHDOG_PERIOD_MASK)

    def deadline(self) -> int | None:
        """Tick at which the counter reaches the period, or None if it can't.

        The prescaler is free-running, so the counter's first step comes at
        the next multiple of 256 after the clearing write: a timeout follows
        the last write by more than (period - 1) * 256 and at most
        period * 256 ticks.
        """
        if self.period == 0 or self._expired:
            return None
        return (self._cleared_at // WATCHDOG_PRESCALER + self.period) * WATCHDOG_PRESCALER

    def expire(self) -> None:
        """Record that the timeout has been handled until the next write."""
        self._expired = True

    def set_period(self, value: int) -> None:
        """Store the 16-bit period written to the watchdog register."""
        self.period = value & WATCHDOG_PERIOD_MASK


PHY_REGISTER_COUNT = 16
GAP_COUNT_DEFAULT = 0x3F
INITIATE_BUS_RESET = 0x40  # IBR bit of PHY register 1
#: Registers the link may change (1: RHB/IBR/gap count, 4, 5, 7).
WRITABLE_PHY_REGISTERS = frozenset({1, 4, 5, 7})


class PhyRegisters:
    """The PHY chip's register file behind the PHY control/data registers.

    Writing ``PHY_WRITE_REQUEST | address << 8 | value`` to the control
    register writes a PHY register; writing ``address << 8`` reads one, and
    the data register then holds ``address << 8 | value``.
    """

    def __init__(self, physical_id: int = 0) -> None:
        self.registers = [0] * PHY_REGISTER_COUNT
        self.registers[1] = GAP_COUNT_DEFAULT
        self.registers[2] = 0xE2  # extended register map, two ports
        self.registers[3] = 0x40  # S400 capable
        self.registers[4] = 0x80  # link active
        self.set_physical_id(physical_id)
        self.control = 0
        self.data = 0

    def set_physical_id(self, physical_id: int) -> None:
        """Record the node number the bus assigned (PHY register 0, bits 7-2)."""
        if not 0 <= physical_id <= BROADCAST_PHY:
            raise ValueError(f"physical id {physical_id} outside 0..{BROADCAST_PHY}")
        self.registers[0] = physical_id << 2

    def request(self, value: int) -> None:
        """Carry out a request written to the PHY control register."""
        self.control = value & 0xFFFF
        address = (value >> PHY_ADDRESS_SHIFT) & PHY_ADDRESS_MASK
        if value & PHY_WRITE_REQUEST:
            if address in WRITABLE_PHY_REGISTERS:
                stored = value & PHY_VALUE_MASK
                if address == 1:
                    # Bus resets belong to the bus model, not to this board.
                    stored &= ~INITIATE_BUS_RESET
                self.registers[address] = stored
            return
        self.data = (address << PHY_ADDRESS_SHIFT) | self.registers[address]
