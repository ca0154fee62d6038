"""Conversions the host library applies between hardware words and API values.

Thesis section 7.2 keeps every API value an integer of a fixed meaning:
ADC samples become unsigned 14-bit numbers, DAC codes stay unsigned 16-bit
numbers centred on their mid-point, encoder periods are signed, and a float
kept in the pot EEPROM occupies two 16-bit words.
"""

from __future__ import annotations

import struct

from fw1394.boards.snake2010.spec import (
    ADC_BITS,
    DAC_MAX,
    DAC_MIDPOINT,
    ENCODER_BITS,
    ENCODER_MIDPOINT,
    POT_EEPROM_WORDS,
    current_feedback_gain,
)

__all__ = [
    "ADC_OFFSET",
    "adc_to_unsigned",
    "count_difference",
    "current_feedback_gain",
    "dac_code",
    "dac_offset",
    "eeprom_index",
    "encoder_offset",
    "float_to_words",
    "sign_extend",
    "split_eeprom_index",
    "words_to_float",
]

#: The library adds the middle of the 14-bit range to each ADC sample.
ADC_OFFSET = 1 << (ADC_BITS - 1)
EEPROM_WORD_BITS = 4


def sign_extend(value: int, bits: int) -> int:
    """Read the low ``bits`` of ``value`` as a two's-complement number."""
    value &= (1 << bits) - 1
    sign = 1 << (bits - 1)
    return (value ^ sign) - sign


def adc_to_unsigned(half_word: int) -> int:
    """API value of one ADC register half: signed 14-bit sample + 8192.

    The ADC sees 0..2.5 V as -1.25..+1.25 V and reports -8192..+8191; the
    API returns 0..16383, so 1.25 V reads 8192.
    """
    return sign_extend(half_word, ADC_BITS) + ADC_OFFSET


def dac_code(offset: int) -> int:
    """DAC code for a signed command ``offset`` around the mid-point.

    The DAC outputs 0..2.5 V for codes 0..65535; the motor turns one way
    above 0x8000 (1.25 V) and the other way below it. Offsets beyond the
    range clip to the ends.
    """
    return min(max(DAC_MIDPOINT + offset, 0), DAC_MAX)


def dac_offset(code: int) -> int:
    """Signed command held by DAC ``code`` (inverse of :func:`dac_code`)."""
    return code - DAC_MIDPOINT


def encoder_offset(count: int) -> int:
    """Encoder count relative to the mid-point the counter is preloaded with."""
    return count - ENCODER_MIDPOINT


def count_difference(new: int, old: int) -> int:
    """Signed change between two 24-bit counter readings, across wrap-around."""
    return sign_extend(new - old, ENCODER_BITS)


def eeprom_index(axis: int, word: int) -> int:
    """EEPROM index of ``word`` on ``axis``: axis in bits 7-4, word in 3-0."""
    if not 0 <= word < POT_EEPROM_WORDS:
        raise ValueError(f"EEPROM word {word} outside 0..{POT_EEPROM_WORDS - 1}")
    if not 0 <= axis <= 0xF:
        raise ValueError(f"axis {axis} does not fit the 4-bit EEPROM index field")
    return (axis << EEPROM_WORD_BITS) | word


def split_eeprom_index(index: int) -> tuple[int, int]:
    """(axis, word) named by an EEPROM ``index``; raises on a bad word."""
    if not 0 <= index <= 0xFF:
        raise ValueError(f"EEPROM index {index:#x} is not an 8-bit value")
    axis, word = index >> EEPROM_WORD_BITS, index & 0xF
    eeprom_index(axis, word)  # validates the word number
    return axis, word


def float_to_words(value: float) -> tuple[int, int]:
    """Split an IEEE single into (high, low) 16-bit words, high first."""
    high, low = struct.unpack(">HH", struct.pack(">f", value))
    return high, low


def words_to_float(high: int, low: int) -> float:
    """Join two 16-bit EEPROM words back into the float they hold."""
    value: float = struct.unpack(">f", struct.pack(">HH", high, low))[0]
    return value
