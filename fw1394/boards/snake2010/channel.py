"""One amplifier channel of the snake board as the FPGA sees it.

Holds the channel's registers (thesis Table 1, devices 0-7): the dual ADC,
the dual DAC, the digital pot's control/data pair and the quadrature
encoder, and wires them to the motor model. The ``wiring`` chooses what is
connected: ``"motor"`` (the amplifier drives a motor, the default) or
``"loopback"`` (the section 8.1 bench test: DAC A feeds the ADC pot input,
DAC B the ADC current input, and nothing moves).
"""

from __future__ import annotations

import math
from typing import Literal

from fw1394.boards.snake2010.physics import UNPOWERED, Drive, MotorAxis, MotorConstants
from fw1394.boards.snake2010.pot import DigitalPot
from fw1394.boards.snake2010.spec import (
    ADC_BITS,
    ADC_HALF_MASK,
    ADC_MAX,
    ADC_MIN,
    ADC_POT_SHIFT,
    DAC_BITS,
    DAC_CODE_MASK,
    DAC_MIDPOINT,
    DAC_READ_LIMIT_SHIFT,
    DAC_SELECT_CURRENT_LIMIT,
    ENCODER_COUNT_MASK,
    ENCODER_OVERFLOW,
    PERIOD_CLOCK_HZ,
    PERIOD_MASK,
    PERIOD_SATURATED,
    VALID_BIT,
    Device,
    current_feedback_gain,
)
from fw1394.engine.space import TICKS_PER_SECOND

Wiring = Literal["motor", "loopback"]

ADC_STEPS = 1 << ADC_BITS
DAC_STEPS = 1 << DAC_BITS
CONVERTER_VOLTS = 2.5


class Channel:
    """Registers and analog front end of one channel (1-based ``number``)."""

    def __init__(self, number: int, constants: MotorConstants, wiring: Wiring) -> None:
        self.number = number
        self.constants = constants
        self.wiring = wiring
        self._loopback = wiring == "loopback"
        self.motor = MotorAxis(constants)
        self.pot = DigitalPot()
        # Invented power-up codes: both DACs at mid-scale (motor stopped).
        self.motor_command = DAC_MIDPOINT
        self.current_limit = DAC_MIDPOINT
        self.preload = 0
        self._count_at_preload = 0
        self._powered = False
        self._drive: Drive | None = None  # cache, rebuilt after register writes
        self._sense_gain = 0.0  # sense volts per amp, follows pot writes
        self._compensation = 0.0  # the drive's compensation_ohms, follows pot writes
        self._follow_pot()
        self._travel_mm = constants.travel_mm
        self._counts_per_rad = constants.encoder_counts_per_rev / (2.0 * math.pi)
        # The real-time block's words, kept until the motor moves or a register
        # changes: a servo loop reads them far more often than a motor at rest changes.
        self._words: tuple[int, int, int] | None = None

    # --- the amplifier ---------------------------------------------------
    @property
    def powered(self) -> bool:
        """True when the amplifier is enabled and its fault line is quiet."""
        return self._powered

    @powered.setter
    def powered(self, value: bool) -> None:
        if value != self._powered:
            self._powered = value
            self._drive = None
            self._words = None

    @property
    def drive(self) -> Drive:
        """Amplifier inputs implied by the registers (cached)."""
        if self._drive is None:
            self._drive = self._build_drive()
        return self._drive

    def _build_drive(self) -> Drive:
        if not self._powered or self._loopback:
            return UNPOWERED
        c = self.constants
        command_volts = (self.motor_command - DAC_MIDPOINT) * CONVERTER_VOLTS / DAC_STEPS
        limit = self.current_limit / DAC_STEPS * c.current_limit_full_scale_amps
        return Drive(True, c.bridge_gain * command_volts, limit, self._compensation)

    def _follow_pot(self) -> None:
        """Take the current-sense gain and the compensation from the pot's wiper and O1."""
        c = self.constants
        gain = current_feedback_gain(self.pot.wiper)
        self._sense_gain = gain * c.sense_ohms
        speed_mode = self.pot.speed_mode
        self._compensation = c.compensation_gain * gain * c.sense_ohms if speed_mode else 0.0

    def current_amps(self) -> float:
        """Motor current now (0 when the amplifier is off)."""
        return self.motor.current_amps(self.drive)

    def realtime_words(self) -> tuple[int, int, int]:
        """ADC, encoder and period words, as :meth:`read` gives them, kept while valid."""
        words = self._words
        if words is None:
            words = self._words = self._fresh_words()
        return words

    def run_motor(self, start: int, target: int, step: int) -> None:
        """Move the motor from tick ``start`` to ``target`` under the present registers.

        A motor held at rest (unpowered, or by stiction) is left as it is, and
        so are its words.
        """
        drive = self._drive
        if drive is None:
            drive = self._drive = self._build_drive()
        motor = self.motor
        if not drive.powered and motor.velocity_rad_s == 0.0:
            return  # idle axes cost nothing, which keeps big buses cheap
        if not motor.held(drive):
            motor.run(start, target, step, TICKS_PER_SECOND, drive)
            self._words = None

    # --- registers -------------------------------------------------------
    def read(self, device: int) -> int:
        """Value of the channel register ``device``; unmapped devices read 0."""
        if device == Device.ADC:
            return self.adc_word()
        if device == Device.DAC:
            return (self.current_limit << DAC_READ_LIMIT_SHIFT) | self.motor_command
        if device == Device.POT_CONTROL:
            return self.pot.control
        if device == Device.POT_DATA:
            return self.pot.data
        if device == Device.ENCODER_PRELOAD:
            return self.preload
        if device == Device.ENCODER_DATA:
            return self.encoder_word()
        if device == Device.ENCODER_PERIOD:
            return self.period_word()
        # Device 7 (frequency) is "not implemented" in the thesis: nothing
        # drives it, so it reads 0 like devices 8-15.
        return 0

    def write(self, device: int, value: int) -> None:
        """Store ``value`` into register ``device``; read-only ones ignore it."""
        if device == Device.DAC:
            self.write_dac(value)
        elif device == Device.POT_CONTROL:
            self.pot.execute(value)
            self._follow_pot()
            self._drive = None
            self._words = None
        elif device == Device.ENCODER_PRELOAD:
            self.preload_encoder(value)

    def write_dac(self, value: int) -> None:
        """Apply one DAC quadlet: valid bit, DAC select bit, 16-bit code."""
        if not value & VALID_BIT:
            return
        code = value & DAC_CODE_MASK
        if value & DAC_SELECT_CURRENT_LIMIT:
            if code == self.current_limit:
                return
            self.current_limit = code
        else:
            if code == self.motor_command:
                return  # a servo loop repeats its command: drive and words stand
            self.motor_command = code
        self._drive = None
        self._words = None

    def preload_encoder(self, value: int) -> None:
        """Load the 24-bit counter and clear its overflow flag."""
        self.preload = value & ENCODER_COUNT_MASK
        self._count_at_preload = self._raw_count(self.motor.angle_rad)
        self.motor.reset_excursion()
        self._words = None

    def adc_word(self) -> int:
        """Pot sample in bits 31-16, motor-current sample in bits 15-0."""
        return self.realtime_words()[0]

    def encoder_word(self) -> int:
        """24-bit count in bits 23-0 and the sticky overflow flag in bit 24."""
        return self.realtime_words()[1]

    def period_word(self) -> int:
        """Signed 16-bit count of 768 kHz clocks between encoder edges.

        Invented details: 0 until the motor first moves; a motor slower than
        the counter can measure (or stopped) reads +/-0x7FFF, signed by the
        direction it last moved in.
        """
        return self.realtime_words()[2]

    def _fresh_words(self) -> tuple[int, int, int]:
        # The three words in one pass over the motor's state: they are rebuilt
        # after every physics span of a moving motor, so this is a hot path.
        # The ADC reports its input (a fraction of 2.5 V) relative to 1.25 V,
        # so 0 V reads -8192, and inputs beyond either end of its range clip.
        motor, floor = self.motor, math.floor
        angle = motor.angle_rad
        if self._loopback:
            pot = self.motor_command / DAC_STEPS
            current = self.current_limit / DAC_STEPS
        else:
            pot = motor.position_mm / self._travel_mm
            current = 0.5 + self._sense_gain * motor.current_amps(self.drive) / CONVERTER_VOLTS
        pot_code = floor(pot * ADC_STEPS) + ADC_MIN
        if pot_code < ADC_MIN:
            pot_code = ADC_MIN
        elif pot_code > ADC_MAX:
            pot_code = ADC_MAX
        current_code = floor(current * ADC_STEPS) + ADC_MIN
        if current_code < ADC_MIN:
            current_code = ADC_MIN
        elif current_code > ADC_MAX:
            current_code = ADC_MAX
        adc = (pot_code & ADC_HALF_MASK) << ADC_POT_SHIFT | current_code & ADC_HALF_MASK
        per_rad, base = self._counts_per_rad, self.preload - self._count_at_preload
        count = base + floor(angle * per_rad)
        overflow = (
            base + floor(motor.lowest_angle_rad * per_rad) < 0
            or base + floor(motor.highest_angle_rad * per_rad) > ENCODER_COUNT_MASK
        )
        encoder = (count & ENCODER_COUNT_MASK) | (ENCODER_OVERFLOW if overflow else 0)
        direction = motor.last_direction
        if direction == 0:
            return adc, encoder, 0
        edges_per_second = abs(motor.velocity_rad_s) * per_rad
        if edges_per_second * PERIOD_SATURATED <= PERIOD_CLOCK_HZ:
            clocks = PERIOD_SATURATED
        else:
            clocks = floor(PERIOD_CLOCK_HZ / edges_per_second)
        return adc, encoder, (direction * clocks) & PERIOD_MASK

    def _raw_count(self, angle_rad: float) -> int:
        return math.floor(angle_rad * self._counts_per_rad)
