"""What the 2010 snake-robot FPGA board looks like from the bus.

Register numbers, bit fields, converter scales and the current-feedback gain
equation of the thesis (Tables 1 and 2, sections 6.2-6.4 and 7.2), plus the
layouts this project defines where the thesis is silent (marked "invented";
see docs/boards/snake2010.md). Both the emulator and the host library import
this module, so the two sides of the wire cannot drift apart.

Register numbers are quadlet indices: bits 7-4 pick a channel (0 = the global
registers), bits 3-0 a device on that channel.
"""

from __future__ import annotations

from enum import IntEnum

# --- Table 1: global registers (channel 0) -------------------------------
REG_STATUS = 0
REG_PHY_CONTROL = 1
REG_PHY_DATA = 2
REG_WATCHDOG_PERIOD = 3
REG_VERSION = 4  # deprecated in the thesis in favour of the pot EEPROM


class Device(IntEnum):
    """Table 1: devices of one channel (register = channel << 4 | device)."""

    ADC = 0
    DAC = 1
    POT_CONTROL = 2
    POT_DATA = 3
    ENCODER_PRELOAD = 4
    ENCODER_DATA = 5
    ENCODER_PERIOD = 6
    ENCODER_FREQUENCY = 7  # listed but "not implemented" in the thesis


CHANNEL_SHIFT = 4
DEVICE_MASK = 0xF
#: The address decoder looks at 8 bits; higher register numbers hit nothing.
HIGHEST_REGISTER = 0xFF
#: Four channel-select bits, channel 0 being the global registers.
MAX_CHANNELS = 15
SNAKE_ACTUATION_CHANNELS = 7
Z_THETA_CHANNELS = 4


def channel_register(channel: int, device: Device) -> int:
    """Quadlet index of ``device`` on ``channel`` (1-based, as in Table 1)."""
    if not 1 <= channel <= MAX_CHANNELS:
        raise ValueError(f"channel {channel} outside 1..{MAX_CHANNELS}")
    return (channel << CHANNEL_SHIFT) | device


# --- Table 2: status register --------------------------------------------
STATUS_BOARD_ID_SHIFT = 24
STATUS_BOARD_ID_MASK = 0xF
STATUS_WATCHDOG_TIMEOUT = 1 << 23
STATUS_FAULT_SHIFT = 16  # bits 22-16, one per amplifier
STATUS_FAULT_MASK = 0x7F
STATUS_ENABLE_MASK_SHIFT = 8  # bits 15-8 on write select which enables change
STATUS_ENABLES_MASK = 0xFF  # bits 7-0


def status_write(mask: int, enables: int) -> int:
    """Status-register write that sets the amplifiers in ``mask`` to ``enables``."""
    return ((mask & 0xFF) << STATUS_ENABLE_MASK_SHIFT) | (enables & mask & 0xFF)


# --- Watchdog (section 6.3) ----------------------------------------------
#: The watchdog counter ticks once per 256 clocks: 49.152 MHz / 256 = 192 kHz.
WATCHDOG_PRESCALER = 256
WATCHDOG_PERIOD_MASK = 0xFFFF

# --- Converters (sections 5.2 and 7.2) -----------------------------------
CONVERTER_FULL_SCALE_VOLTS = 2.5
CONVERTER_MIDPOINT_VOLTS = 1.25
ADC_BITS = 14
ADC_MIN = -(1 << (ADC_BITS - 1))  # -8192 at 0 V
ADC_MAX = (1 << (ADC_BITS - 1)) - 1  # +8191 just below 2.5 V
DAC_BITS = 16
DAC_MIDPOINT = 1 << (DAC_BITS - 1)  # 0x8000 = 1.25 V = motor stopped
DAC_MAX = (1 << DAC_BITS) - 1

#: Invented: the ADC data register carries the pot sample in bits 31-16 and
#: the motor-current sample in bits 15-0, each a 14-bit two's-complement
#: value sign-extended to 16 bits (the JHU boards use the same halves).
ADC_POT_SHIFT = 16
ADC_HALF_MASK = 0xFFFF

#: Invented DAC control quadlet (also the data quadlet of a real-time block
#: write): bit 31 valid, bit 16 selects DAC B (current limit) instead of
#: DAC A (motor command), bits 15-0 the code. One quadlet can only ever name
#: one DAC, which is how "never both in one transaction" holds.
VALID_BIT = 1 << 31
DAC_SELECT_CURRENT_LIMIT = 1 << 16
DAC_CODE_MASK = 0xFFFF
#: Invented read-back: current limit in bits 31-16, motor command in 15-0.
DAC_READ_LIMIT_SHIFT = 16

# --- Encoder (section 7.2) -----------------------------------------------
ENCODER_BITS = 24
ENCODER_COUNT_MASK = (1 << ENCODER_BITS) - 1
ENCODER_MIDPOINT = 1 << (ENCODER_BITS - 1)
ENCODER_OVERFLOW = 1 << ENCODER_BITS  # bit 24, sticky until the next preload
#: The period counter runs at 49.152 MHz / 64 = 768 kHz.
PERIOD_CLOCK_HZ = 768_000
PERIOD_MASK = 0xFFFF
PERIOD_SATURATED = 0x7FFF

# --- Digital potentiometer (sections 5.2, 6.2, 7.2) ----------------------
WIPER_MAX = 1023
POT_EEPROM_WORDS = 14
OUTPUT_O1 = 1  # high selects speed control, low torque control
OUTPUT_O2 = 2
#: Invented command frame written to the pot control register; it mirrors a
#: 24-bit SPI frame: command in bits 23-20, EEPROM word in 19-16, data 15-0.
POT_COMMAND_SHIFT = 20
POT_ADDRESS_SHIFT = 16
POT_ECHO_MASK = 0x00FF_0000
POT_DATA_MASK = 0xFFFF
#: Set in the pot data register when it holds the answer to a read command.
POT_DATA_VALID = 1 << 31


class PotCommand(IntEnum):
    """Invented command codes of the pot control register."""

    NOP = 0
    READ_WIPER = 1
    WRITE_WIPER = 2
    READ_EEPROM = 3
    WRITE_EEPROM = 4
    READ_OUTPUTS = 5
    WRITE_OUTPUTS = 6


POT_READ_COMMANDS = frozenset(
    {PotCommand.READ_WIPER, PotCommand.READ_EEPROM, PotCommand.READ_OUTPUTS}
)


def pot_frame(command: PotCommand, address: int = 0, data: int = 0) -> int:
    """Pot control-register value asking the pot to do ``command``."""
    return (
        (command << POT_COMMAND_SHIFT)
        | ((address & 0xF) << POT_ADDRESS_SHIFT)
        | (data & POT_DATA_MASK)
    )


def current_feedback_gain(wiper: int) -> float:
    """Gain of the motor-current feedback stage, thesis equation (1).

    The 10-ohm digital pot sits between a 12.1-ohm and a 1.5-ohm resistor,
    so moving the wiper towards B raises the numerator and lowers the
    denominator; wiper 375 gives the nominal gain of about 2.
    """
    if not 0 <= wiper <= WIPER_MAX:
        raise ValueError(f"wiper {wiper} outside 0..{WIPER_MAX}")
    upper = 12.1 + 10.0 * wiper / WIPER_MAX
    lower = 1.5 + 10.0 * (WIPER_MAX - wiper) / WIPER_MAX
    return upper / lower


# --- PHY access (invented register formats) ------------------------------
PHY_WRITE_REQUEST = 1 << 12
PHY_ADDRESS_SHIFT = 8
PHY_ADDRESS_MASK = 0xF
PHY_VALUE_MASK = 0xFF

#: Invented value of the deprecated version register: the thesis's final
#: hardware and firmware are "Revision 2".
FIRMWARE_VERSION = 2

# --- Block transfers (section 6.4, JHU Rev 1-6 layout, invented sizes) ---
REALTIME_OFFSET = 0
RT_HEADER_QUADLETS = 4  # timestamp, status, two reserved quadlets
RT_READ_FIELDS_PER_CHANNEL = 4  # ADC, encoder data, period, frequency
#: 512 quadlets is the largest S400 payload (thesis section 8.3).
MAX_BLOCK_BYTES = 2048


def rt_read_quadlets(channels: int) -> int:
    """Size of the real-time block read: 32 quadlets for 7 channels."""
    return RT_HEADER_QUADLETS + RT_READ_FIELDS_PER_CHANNEL * channels


def rt_write_quadlets(channels: int) -> int:
    """Size of the real-time block write: one DAC quadlet per channel."""
    return channels


class RtRead(IntEnum):
    """Quadlet positions in the real-time block read header."""

    TIMESTAMP = 0
    STATUS = 1
    RESERVED_DIGITAL_IO = 2
    RESERVED_TEMPERATURE = 3


def rt_adc_index(channel: int) -> int:
    """Quadlet of channel ``channel``'s ADC word (channels are 1-based)."""
    return RT_HEADER_QUADLETS + (channel - 1)


def rt_encoder_index(channel: int, channels: int) -> int:
    """Quadlet of channel ``channel``'s encoder data word."""
    return RT_HEADER_QUADLETS + channels + (channel - 1)


def rt_period_index(channel: int, channels: int) -> int:
    """Quadlet of channel ``channel``'s encoder period word."""
    return RT_HEADER_QUADLETS + 2 * channels + (channel - 1)


def rt_frequency_index(channel: int, channels: int) -> int:
    """Quadlet of channel ``channel``'s (unimplemented) frequency word."""
    return RT_HEADER_QUADLETS + 3 * channels + (channel - 1)
