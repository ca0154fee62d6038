"""Engineering units for the view: the "conversion factors" of the thesis's test program.

The converter scales (ADC and DAC over 0..2.5 V, the 768 kHz period clock)
are the board's own. Turning volts into millimetres, amperes and motor volts
needs the motor and amplifier constants; the defaults are the emulator's
:class:`~fw1394.boards.snake2010.physics.MotorConstants`, so the figures
agree with what the emulated motors do.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.boards.snake2010.physics import MotorConstants
from fw1394.boards.snake2010.spec import (
    ADC_BITS,
    CONVERTER_FULL_SCALE_VOLTS,
    CONVERTER_MIDPOINT_VOLTS,
    DAC_BITS,
    DAC_MIDPOINT,
    ENCODER_MIDPOINT,
    PERIOD_CLOCK_HZ,
    PERIOD_SATURATED,
    WATCHDOG_PRESCALER,
)
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host.units import current_feedback_gain

ADC_STEPS = 1 << ADC_BITS
DAC_STEPS = 1 << DAC_BITS


def adc_volts(value: int) -> float:
    """Input voltage of an ADC API value (0..16383 spans 0..2.5 V)."""
    return value * CONVERTER_FULL_SCALE_VOLTS / ADC_STEPS


def dac_volts(code: int) -> float:
    """Output voltage of a DAC code (0..65535 spans 0..2.5 V)."""
    return code * CONVERTER_FULL_SCALE_VOLTS / DAC_STEPS


def encoder_offset(count: int) -> int:
    """Count relative to the mid-point hosts preload (thesis 7.2)."""
    return count - ENCODER_MIDPOINT


def period_saturated(period: int) -> bool:
    """The period counter ran out: edges are more than 42.7 ms apart, or none came."""
    return abs(period) >= PERIOD_SATURATED


def counts_per_second(period: int) -> float:
    """Encoder speed from the signed edge period; 0 when stopped or never moved."""
    if period == 0 or period_saturated(period):
        return 0.0
    return PERIOD_CLOCK_HZ / period


@dataclass(frozen=True)
class Conversions:
    """Factors from converter values to physical units for one kind of axis."""

    sense_ohms: float
    bridge_gain: float
    current_limit_full_scale_amps: float
    travel_mm: float

    @classmethod
    def of(cls, constants: MotorConstants | None = None) -> Conversions:
        c = constants or MotorConstants()
        return cls(c.sense_ohms, c.bridge_gain, c.current_limit_full_scale_amps, c.travel_mm)

    def pot_mm(self, value: int) -> float:
        """Actuator position: the pot spans 0..2.5 V over the travel."""
        return adc_volts(value) / CONVERTER_FULL_SCALE_VOLTS * self.travel_mm

    def current_amps(self, value: int, wiper: int) -> float:
        """Motor current: the sense voltage is gained by equation (1) around 1.25 V."""
        gain = current_feedback_gain(wiper)
        return (adc_volts(value) - CONVERTER_MIDPOINT_VOLTS) / (gain * self.sense_ohms)

    def motor_volts(self, code: int) -> float:
        """Voltage the bridge is asked to put across the motor (before its rails)."""
        return self.bridge_gain * (dac_volts(code) - dac_volts(DAC_MIDPOINT))

    def limit_amps(self, code: int) -> float:
        """Current limit set by DAC B."""
        return code / DAC_STEPS * self.current_limit_full_scale_amps


def watchdog_seconds(period: int) -> float:
    """Time without a write after which the watchdog switches the amplifiers off."""
    return period * WATCHDOG_PRESCALER / TICKS_PER_SECOND


def ticks_seconds(ticks: int) -> float:
    """Seconds of the board's 49.152 MHz clock."""
    return ticks / TICKS_PER_SECOND
