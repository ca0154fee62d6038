"""Emulated FPGA node of the 2010 snake-robot motor controller.

Register-level model of the board in P. Thienphrapa's 2010 thesis (sections
5-6): the global registers of Table 1 (status, PHY window, watchdog,
version), 1-7 channels of ADC/DAC/digital pot/encoder registers, the status
word of Table 2 with its masked amplifier-enable writes, the watchdog of
section 6.3, the real-time block read and write of section 6.4, and one
deterministic motor per channel so that commands move the encoder and pot.

Offsets are decoded as quadlet indices (low 16 bits of the 48-bit offset).
Unmapped registers read 0 and ignore writes, as the thesis's decoder simply
has nothing behind them; no address errors are raised. Time advances only
through :meth:`Snake2010Board.set_time`. docs/boards/snake2010.md has the
full description, including what was invented where the thesis is silent.
"""

from __future__ import annotations

import struct
from dataclasses import dataclass

from fw1394.boards.regmap import FIREWIRE
from fw1394.boards.snake2010.channel import Channel, Wiring
from fw1394.boards.snake2010.global_io import PhyRegisters, Watchdog
from fw1394.boards.snake2010.physics import MotorConstants
from fw1394.boards.snake2010.regmap import REGISTER_MAP
from fw1394.boards.snake2010.spec import (
    CHANNEL_SHIFT,
    DEVICE_MASK,
    FIRMWARE_VERSION,
    HIGHEST_REGISTER,
    MAX_BLOCK_BYTES,
    REALTIME_OFFSET,
    REG_PHY_CONTROL,
    REG_PHY_DATA,
    REG_STATUS,
    REG_VERSION,
    REG_WATCHDOG_PERIOD,
    RT_HEADER_QUADLETS,
    SNAKE_ACTUATION_CHANNELS,
    STATUS_BOARD_ID_MASK,
    STATUS_BOARD_ID_SHIFT,
    STATUS_ENABLE_MASK_SHIFT,
    STATUS_FAULT_SHIFT,
    STATUS_WATCHDOG_TIMEOUT,
)
from fw1394.engine.space import AddressError, DataError

#: Planted defects this board understands; other names are left for the
#: packet layers, which receive the same set.
BOARD_DEFECTS = frozenset({"stale-read", "write-ignores-mask"})
#: Physics step: 0.25 ms (4 kHz), a quarter of the thesis's servo period.
DEFAULT_PHYSICS_STEP_TICKS = 12_288
#: The status register has seven fault bits, so seven amplifiers at most.
MAX_AMPLIFIERS = 7
OFFSET_LIMIT = 1 << 48
#: Offset to quadlet index, as the register map says the board decodes.
_decode = REGISTER_MAP.decodings[FIREWIRE].address


@dataclass(frozen=True)
class AxisState:
    """What an observer (UI, plot) can see of one channel's hardware."""

    position_mm: float
    velocity_rad_s: float
    current_amps: float
    enabled: bool
    faulted: bool
    led: bool


class Snake2010Board:
    """One snake-robot FPGA node; implements :class:`AddressSpace`."""

    def __init__(
        self,
        *,
        board_id: int,
        defects: frozenset[str] = frozenset(),
        channels: int = SNAKE_ACTUATION_CHANNELS,
        wiring: Wiring = "motor",
        constants: MotorConstants | None = None,
        physics_step_ticks: int = DEFAULT_PHYSICS_STEP_TICKS,
        physical_id: int = 0,
    ) -> None:
        if not 0 <= board_id <= STATUS_BOARD_ID_MASK:
            raise ValueError(f"board_id {board_id} does not fit the 4-bit rotary switch")
        if not 1 <= channels <= MAX_AMPLIFIERS:
            raise ValueError(f"channels must be 1..{MAX_AMPLIFIERS}, not {channels}")
        if physics_step_ticks <= 0:
            raise ValueError("physics_step_ticks must be positive")
        motor = constants or MotorConstants()
        self.board_id = board_id
        self.defects = frozenset(defects)
        self.channels = tuple(Channel(n, motor, wiring) for n in range(1, channels + 1))
        self.watchdog = Watchdog()
        self.phy = PhyRegisters(physical_id)
        self._step = physics_step_ticks
        self._amplifier_bits = (1 << channels) - 1
        self._enables = 0
        self._faults = 0
        self._watchdog_timed_out = False
        self._now = 0
        self._last_realtime_read = 0
        self._previous_block: bytes | None = None
        # elapsed, status, reserved zeros; ADC, encoder, period words; zeros.
        n = len(self.channels)
        self._rt_layout = struct.Struct(f">2I{4 * (RT_HEADER_QUADLETS - 2)}x{3 * n}I{4 * n}x")

    # --- observation (not reachable over the bus) --------------------------
    @property
    def now(self) -> int:
        """The board's clock, in 49.152 MHz ticks."""
        return self._now

    @property
    def status(self) -> int:
        """Status register (Table 2); the enable mask bits 15-8 read as 0."""
        word = self.board_id << STATUS_BOARD_ID_SHIFT
        if self._watchdog_timed_out:
            word |= STATUS_WATCHDOG_TIMEOUT
        return word | (self._faults << STATUS_FAULT_SHIFT) | self._enables

    @property
    def leds(self) -> tuple[bool, ...]:
        """LED per amplifier: lit when enabled and its fault line is quiet."""
        return tuple(channel.powered for channel in self.channels)

    def axis_state(self, channel: int) -> AxisState:
        """Physical state behind channel ``channel`` (1-based)."""
        ch = self._channel(channel)
        bit = 1 << (channel - 1)
        return AxisState(
            position_mm=ch.motor.position_mm,
            velocity_rad_s=ch.motor.velocity_rad_s,
            current_amps=ch.current_amps(),
            enabled=bool(self._enables & bit),
            faulted=bool(self._faults & bit),
            led=ch.powered,
        )

    def set_amplifier_fault(self, channel: int, asserted: bool) -> None:
        """Drive channel ``channel``'s op-amp fault line (e.g. overheating).

        A faulted amplifier stops driving its motor; its enable bit stays as
        the host left it, so it resumes when the fault clears.
        """
        self._channel(channel)
        bit = 1 << (channel - 1)
        self._faults = self._faults | bit if asserted else self._faults & ~bit
        self._update_amplifiers()

    # --- AddressSpace --------------------------------------------------------
    def read_quadlet(self, offset: int) -> int:
        return self._read_register(_register_index(offset))

    def write_quadlet(self, offset: int, value: int) -> None:
        index = _register_index(offset)
        if not 0 <= value <= 0xFFFF_FFFF:
            raise DataError(f"quadlet value {value:#x} does not fit 32 bits")
        self.watchdog.feed(self._now)
        self._write_register(index, value)

    def read_block(self, offset: int, length: int) -> bytes:
        index = _register_index(offset)
        _check_block_length(length)
        if index == REALTIME_OFFSET:
            block = self._realtime_block()
        else:
            count = (length + 3) // 4
            words = [self._read_register(index + i) for i in range(count)]
            block = struct.pack(f">{count}I", *words)
        # Odd sizes are accepted (thesis 6.1): cut short or pad with zeros.
        return block[:length].ljust(length, b"\0")

    def write_block(self, offset: int, data: bytes) -> None:
        index = _register_index(offset)
        _check_block_length(len(data))
        self.watchdog.feed(self._now)
        count = len(data) // 4  # a trailing partial quadlet is dropped
        words = struct.unpack(f">{count}I", data[: 4 * count])
        if index == REALTIME_OFFSET:
            for channel, word in zip(self.channels, words, strict=False):
                channel.write_dac(word)
        else:
            for i, word in enumerate(words):
                self._write_register(index + i, word)

    def set_time(self, ticks: int) -> None:
        if ticks < self._now:
            raise ValueError(f"time went backwards: {ticks} < {self._now}")
        while True:
            deadline = self.watchdog.deadline()
            if deadline is None or deadline > ticks:
                self._run_physics(ticks)
                return
            self._run_physics(max(deadline, self._now))
            self._watchdog_timeout()

    # --- internals -------------------------------------------------------------
    def _channel(self, channel: int) -> Channel:
        if not 1 <= channel <= len(self.channels):
            raise ValueError(f"channel {channel} outside 1..{len(self.channels)}")
        return self.channels[channel - 1]

    def _read_register(self, index: int) -> int:
        if index > HIGHEST_REGISTER:
            return 0
        channel, device = index >> CHANNEL_SHIFT, index & DEVICE_MASK
        if channel == 0:
            return self._read_global(device)
        if channel <= len(self.channels):
            return self.channels[channel - 1].read(device)
        return 0

    def _read_global(self, device: int) -> int:
        if device == REG_STATUS:
            return self.status
        if device == REG_PHY_CONTROL:
            return self.phy.control
        if device == REG_PHY_DATA:
            return self.phy.data
        if device == REG_WATCHDOG_PERIOD:
            return self.watchdog.period
        if device == REG_VERSION:
            return FIRMWARE_VERSION
        return 0

    def _write_register(self, index: int, value: int) -> None:
        if index > HIGHEST_REGISTER:
            return
        channel, device = index >> CHANNEL_SHIFT, index & DEVICE_MASK
        if channel == 0:
            self._write_global(device, value)
        elif channel <= len(self.channels):
            self.channels[channel - 1].write(device, value)

    def _write_global(self, device: int, value: int) -> None:
        if device == REG_STATUS:
            self._write_status(value)
        elif device == REG_PHY_CONTROL:
            self.phy.request(value)
        elif device == REG_WATCHDOG_PERIOD:
            self.watchdog.set_period(value)
        # PHY data and version are read-only; other devices are unmapped.

    def _write_status(self, value: int) -> None:
        mask = (value >> STATUS_ENABLE_MASK_SHIFT) & 0xFF
        if "write-ignores-mask" in self.defects:
            mask = 0xFF  # planted bug: every amplifier takes bits 7-0
        mask &= self._amplifier_bits
        requested_on = value & mask
        self._enables = (self._enables & ~mask) | requested_on
        if requested_on:
            # Invented (as on the later JHU boards): asking for power again
            # acknowledges a watchdog timeout.
            self._watchdog_timed_out = False
        self._update_amplifiers()

    def _update_amplifiers(self) -> None:
        powered = self._enables & ~self._faults
        for number, channel in enumerate(self.channels):
            channel.powered = bool(powered >> number & 1)

    def _watchdog_timeout(self) -> None:
        self.watchdog.expire()
        self._watchdog_timed_out = True
        self._enables = 0
        self._update_amplifiers()

    def _run_physics(self, target: int) -> None:
        # Steps sit on a fixed grid of absolute ticks, so the motion does not
        # depend on how often the clock is set, only on when registers change.
        now = self._now
        if now >= target:
            return
        self._now = target
        # Registers cannot change meanwhile, so each drive holds for the span.
        step = self._step
        for channel in self.channels:
            channel.run_motor(now, target, step)

    def _realtime_block(self) -> bytes:
        elapsed = (self._now - self._last_realtime_read) & 0xFFFF_FFFF
        self._last_realtime_read = self._now
        # Laid out by kind (every ADC word, then every encoder word, every period
        # word, and the unimplemented frequency words as zeros).
        adc, encoder, period = zip(*[ch.realtime_words() for ch in self.channels], strict=True)
        block = self._rt_layout.pack(elapsed, self.status, *adc, *encoder, *period)
        if "stale-read" in self.defects:
            # Planted bug: hand out the block latched by the previous read.
            previous, self._previous_block = self._previous_block, block
            if previous is not None:
                block = previous
        return block


def _register_index(offset: int) -> int:
    if not 0 <= offset < OFFSET_LIMIT:
        raise AddressError(f"offset {offset:#x} is not a 48-bit 1394 offset")
    return _decode(offset)


def _check_block_length(length: int) -> None:
    if not 0 <= length <= MAX_BLOCK_BYTES:
        raise DataError(f"block of {length} bytes; this board handles 0..{MAX_BLOCK_BYTES}")
