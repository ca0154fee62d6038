"""Power, relay, amplifier enables and digital I/O: what STATUS reports and commands.

A STATUS write is a set of masked commands, never a value to store: bit 17
masks bit 16 (safety relay), bit 19 masks bit 18 (motor power), bits 11..8
mask bits 3..0 (amplifier enables), bit 21 masks bit 20 (reboot). Bits 22,
23 and 24 retrigger hardware detections that this model has no state for.
Following the firmware (BoardRegs.v, RTL reading): an amplifier can only
be enabled while power was already on before the write, and any STATUS
write made with power off disables every amplifier.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from fw1394.boards.qla1.regs import (
    AMP_BITS,
    CHANNELS,
    COMMAND_AMP_MASK_SHIFT,
    COMMAND_POWER_MASK,
    COMMAND_POWER_VALUE,
    COMMAND_REBOOT_MASK,
    COMMAND_REBOOT_VALUE,
    COMMAND_RELAY_MASK,
    COMMAND_RELAY_VALUE,
    STATUS_AMP_ON_SHIFT,
    STATUS_BOARD_ID_SHIFT,
    STATUS_CHANNELS_SHIFT,
    STATUS_MOTOR_VOLTAGE_GOOD,
    STATUS_POWER_ENABLE,
    STATUS_RELAY_FEEDBACK,
    STATUS_RELAY_ON,
    STATUS_WATCHDOG_TIMEOUT,
)

#: DIGIN bit 28: motor supply comparator, high while motor power is on.
DIGIN_MOTOR_SUPPLY = 1 << 28
DIGIN_DOUT_SHIFT = 12


class StatusCommand(NamedTuple):
    """What a STATUS write asked for, beyond the state changes it made (a tuple: every
    real-time write carries a STATUS write for each board)."""

    asks_for_power: bool  # power or an amplifier enable: clears the watchdog flag
    reboot: bool


#: Every StatusCommand there is, made once (a board makes one per STATUS write).
_COMMANDS = {
    (asks_for_power, reboot): StatusCommand(asks_for_power, reboot)
    for asks_for_power in (False, True)
    for reboot in (False, True)
}


@dataclass
class BoardControl:
    """Relay, motor power, amplifier disables (firmware's reg_disable) and DOUT."""

    relay_on: bool = False
    power_enable: bool = False
    amps_disabled: int = AMP_BITS
    digital_outputs: int = 0

    @property
    def amps_enabled(self) -> int:
        return ~self.amps_disabled & AMP_BITS

    @property
    def amps_on(self) -> int:
        """The amplifiers driving their motors (bit n-1: channel n): enabled and powered."""
        return self.amps_enabled if self.power_enable else 0

    def amp_on(self, channel: int) -> bool:
        """An amplifier drives its motor only when enabled and powered."""
        return bool(self.amps_on >> (channel - 1) & 1)

    def status(self, board_id: int, watchdog_timeout: bool) -> int:
        """STATUS as read; all flags the model does not simulate read as 0."""
        value = CHANNELS << STATUS_CHANNELS_SHIFT | board_id << STATUS_BOARD_ID_SHIFT
        if watchdog_timeout:
            value |= STATUS_WATCHDOG_TIMEOUT
        if self.power_enable:
            value |= STATUS_POWER_ENABLE | STATUS_MOTOR_VOLTAGE_GOOD
        if self.relay_on:
            value |= STATUS_RELAY_ON | STATUS_RELAY_FEEDBACK
        return value | self.amps_on << STATUS_AMP_ON_SHIFT | self.amps_enabled

    def command(self, value: int) -> StatusCommand:
        """Apply a STATUS write."""
        powered_before = self.power_enable
        masks = (value >> COMMAND_AMP_MASK_SHIFT) & AMP_BITS
        wanted = value & AMP_BITS
        disabled = (self.amps_disabled & ~masks) | (~wanted & masks)
        self.amps_disabled = (disabled if powered_before else AMP_BITS) & AMP_BITS
        if value & COMMAND_RELAY_MASK:
            self.relay_on = bool(value & COMMAND_RELAY_VALUE)
        if value & COMMAND_POWER_MASK:
            self.power_enable = bool(value & COMMAND_POWER_VALUE)
        asks_for_power = bool(
            (value & COMMAND_POWER_MASK and value & COMMAND_POWER_VALUE) or masks & wanted
        )
        reboot = bool(value & COMMAND_REBOOT_MASK and value & COMMAND_REBOOT_VALUE)
        return _COMMANDS[asks_for_power, reboot]

    def request_amp(self, channel: int, enable: bool) -> None:
        """A Rev 8+ DAC command's enable bit, under the same power rule as STATUS."""
        bit = 1 << (channel - 1)
        if enable and self.power_enable:
            self.amps_disabled &= ~bit
        else:
            self.amps_disabled |= bit

    def disable_all_amps(self) -> None:
        self.amps_disabled = AMP_BITS

    def write_digital_outputs(self, value: int) -> None:
        """DIGOUT write: bits 11..8 mask bits 3..0."""
        masks = (value >> 8) & 0xF
        self.digital_outputs = (self.digital_outputs & ~masks | value & masks) & 0xF

    def digital_input(self) -> int:
        """DIGIN: no switch, limit or encoder line active; DOUT and supply state mirrored."""
        value = self.digital_outputs << DIGIN_DOUT_SHIFT
        if self.power_enable:
            value |= DIGIN_MOTOR_SUPPLY
        return value
