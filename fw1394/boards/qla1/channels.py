"""One QLA motor channel: a deterministic stand-in for the amplifier, DAC and encoder.

Nothing moves: the encoder stays where it was preloaded, the pot reads a
fixed value per channel, and the measured current equals the commanded one
while the amplifier is on (midrange, i.e. zero current, while it is off).
That is enough for host software to see its own commands reflected.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.boards.qla1.regs import (
    DAC_ENABLE,
    DAC_ENABLE_MASK,
    DAC_MIDRANGE,
    DAC_VALID,
    DAC_VALUE_MASK,
    DAC_VOLTAGE_MODE,
    ENCODER_MIDRANGE,
    ENCODER_POSITION_MASK,
    MOTOR_CONFIG_CURRENT_AVAILABLE,
    MOTOR_CONFIG_SET_DELAY,
    MOTOR_CONFIG_SET_LIMIT,
    MOTOR_STATUS_AMP_ON,
    MOTOR_STATUS_ENABLE_REQUESTED,
    ChannelRegister,
)

#: Firmware 6 and later flag a stalled encoder with the period overflow bit.
PERIOD_OVERFLOW_REV6 = 0x80000000
#: Older firmware marks the overflow with the 16-bit value 0x8000.
PERIOD_OVERFLOW_OLD = 0x00008000


@dataclass
class MotorChannel:
    """State of channel ``number`` (1..4) and its register reads and writes."""

    number: int
    firmware: int
    dac_command: int = DAC_MIDRANGE
    voltage_mode: bool = False
    encoder_preload: int = ENCODER_MIDRANGE
    encoder_position: int = ENCODER_MIDRANGE
    dout_control: int = 0
    current_limit: int = 0xFFFF
    enable_delay: int = 0

    @property
    def pot_reading(self) -> int:
        # A fixed, per-channel value near midrange so tests can tell channels apart.
        return 0x8000 + 0x100 * self.number

    def current_reading(self, amp_on: bool) -> int:
        return self.dac_command if amp_on else DAC_MIDRANGE

    def adc(self, amp_on: bool) -> int:
        return (self.pot_reading << 16) | self.current_reading(amp_on)

    def encoder_data(self) -> int:
        # Bits 28..30 (A/B/index levels, Rev 8+) and bit 24 (overflow) stay 0: nothing moves.
        return self.encoder_position & ENCODER_POSITION_MASK

    def encoder_period(self) -> int:
        return PERIOD_OVERFLOW_REV6 if self.firmware >= 6 else PERIOD_OVERFLOW_OLD

    def motor_config(self) -> int:
        return (
            MOTOR_CONFIG_CURRENT_AVAILABLE
            | (self.enable_delay & 0xFF) << 16
            | (self.current_limit & 0xFFFF)
        )

    @staticmethod
    def motor_status(amp_on: bool) -> int:
        if not amp_on:
            return 0
        return MOTOR_STATUS_AMP_ON | MOTOR_STATUS_ENABLE_REQUESTED

    def read(self, register: int, amp_on: bool) -> int:
        """Value of channel register ``register`` (0..15); 0 where nothing is mapped."""
        if register == ChannelRegister.ADC:
            return self.adc(amp_on)
        if register == ChannelRegister.DAC:
            return self.dac_command
        if register == ChannelRegister.ENCODER_PRELOAD:
            return self.encoder_preload
        if register == ChannelRegister.ENCODER_POSITION:
            return self.encoder_data()
        if register == ChannelRegister.ENCODER_PERIOD:
            return self.encoder_period()
        if register == ChannelRegister.DOUT_CONTROL:
            return self.dout_control
        if register == ChannelRegister.MOTOR_CONFIG and self.firmware >= 8:
            return self.motor_config()
        if register == ChannelRegister.MOTOR_STATUS and self.firmware >= 8:
            return self.motor_status(amp_on)
        # QTR1, QTR5 and the running counter: a stalled encoder has no edges to time.
        return 0

    def write(self, register: int, value: int) -> bool | None:
        """Apply a write; returns the amplifier enable a Rev 8+ DAC write asks for, if any."""
        if register == ChannelRegister.DAC:
            return self.write_dac(value)
        if register == ChannelRegister.ENCODER_PRELOAD:
            self.encoder_preload = value & ENCODER_POSITION_MASK
            self.encoder_position = self.encoder_preload
        elif register == ChannelRegister.DOUT_CONTROL:
            self.dout_control = value
        elif register == ChannelRegister.MOTOR_CONFIG and self.firmware >= 8:
            # Bits 24/25 say which of the two fields this write sets.
            if value & MOTOR_CONFIG_SET_LIMIT:
                self.current_limit = value & 0xFFFF
            if value & MOTOR_CONFIG_SET_DELAY:
                self.enable_delay = (value >> 16) & 0xFF
        return None

    def write_dac(self, value: int) -> bool | None:
        """A DAC command: stored only when its valid bit is set."""
        if value & DAC_VALID:
            self.dac_command = value & DAC_VALUE_MASK
            self.voltage_mode = bool(value & DAC_VOLTAGE_MODE)
        if self.firmware >= 8 and value & DAC_ENABLE_MASK:
            return bool(value & DAC_ENABLE)
        return None
