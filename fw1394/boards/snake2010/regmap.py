"""The snake-board register map (thesis Table 1) as data.

Numbers come from :mod:`fw1394.boards.snake2010.spec`; this module adds what
each register is and how an offset reaches it. docs/boards/snake2010.md
prints these tables.
"""

from __future__ import annotations

from fw1394.boards.regmap import FIREWIRE, Decoding, Group, Register, RegisterMap
from fw1394.boards.snake2010.spec import (
    FIRMWARE_VERSION,
    HIGHEST_REGISTER,
    REG_PHY_CONTROL,
    REG_PHY_DATA,
    REG_STATUS,
    REG_VERSION,
    REG_WATCHDOG_PERIOD,
    SNAKE_ACTUATION_CHANNELS,
    Device,
)

#: The board reads offset bits 15..0 as a quadlet index; higher bits alias.
INDEX_BITS = 0xFFFF

GLOBAL = Group(
    "global",
    (
        Register(
            "STATUS",
            REG_STATUS,
            "rw",
            None,
            "Table 2 word (below)",
            "masked amplifier enables",
            label="Status",
        ),
        Register(
            "PHY_CONTROL",
            REG_PHY_CONTROL,
            "rw",
            0,
            "last request written (invented)",
            "PHY request (invented format below)",
            label="PHY control",
        ),
        Register(
            "PHY_DATA",
            REG_PHY_DATA,
            "ro",
            0,
            "`address << 8 \\| value` of the last PHY read (invented)",
            "ignored",
            label="PHY data",
        ),
        Register(
            "WATCHDOG_PERIOD",
            REG_WATCHDOG_PERIOD,
            "rw",
            0,
            "period, bits 15-0",
            "period, bits 15-0; 0 disables",
            label="Watchdog period",
            bits=16,
        ),
        Register(
            "VERSION",
            REG_VERSION,
            "ro",
            FIRMWARE_VERSION,
            '2, for "Revision 2" (invented value)',
            "ignored",
            label="Version (deprecated)",
        ),
    ),
)

CHANNEL = Group(
    "channel",
    (
        Register(
            "ADC",
            Device.ADC,
            "ro",
            None,
            "pot in 31-16, motor current in 15-0",
            "ignored",
            label="ADC data",
        ),
        Register(
            "DAC",
            Device.DAC,
            "rw",
            0x8000_8000,
            "current limit in 31-16, motor command in 15-0 (invented)",
            "DAC quadlet (below)",
            label="DAC control",
        ),
        Register(
            "POT_CONTROL",
            Device.POT_CONTROL,
            "rw",
            0,
            "last command frame written",
            "command frame (below)",
            label="Pot control",
        ),
        Register(
            "POT_DATA",
            Device.POT_DATA,
            "ro",
            0,
            "answer to the last command (below)",
            "ignored",
            label="Pot data",
        ),
        Register(
            "ENCODER_PRELOAD",
            Device.ENCODER_PRELOAD,
            "rw",
            0,
            "last preload, bits 23-0",
            "load counter (bits 23-0), clear overflow",
            label="Encoder preload",
            bits=24,
        ),
        Register(
            "ENCODER_DATA",
            Device.ENCODER_DATA,
            "ro",
            0,
            "count 23-0, overflow flag bit 24",
            "ignored",
            label="Encoder data",
            bits=25,
        ),
        Register(
            "ENCODER_PERIOD",
            Device.ENCODER_PERIOD,
            "ro",
            0,
            "signed 16-bit, bits 15-0",
            "ignored",
            label="Encoder period",
            bits=16,
        ),
        Register(
            "ENCODER_FREQUENCY",
            Device.ENCODER_FREQUENCY,
            "ro",
            0,
            "always 0",
            "ignored",
            label="Encoder frequency",
        ),
    ),
    copies=range(1, SNAKE_ACTUATION_CHANNELS + 1),
    stride=0x10,
)

REGISTER_MAP = RegisterMap(
    "snake2010",
    (GLOBAL, CHANNEL),
    decodings={FIREWIRE: Decoding(kept=INDEX_BITS)},
    probe="VERSION",
    # Unmapped global devices and both edges of the 8-bit register decoder.
    spots=(5, 6, 7, HIGHEST_REGISTER, HIGHEST_REGISTER + 1),
)
