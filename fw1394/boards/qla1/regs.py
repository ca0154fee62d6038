"""Register numbers, bit masks and fixed values of the QLA1 personality.

The board decodes only bits 15..0 of a 1394 offset, as a quadlet index:
bits 15..12 select an address space, and in the MAIN space bits 7..4 select
the channel (0 = board registers) and bits 3..0 the register.
"""

from __future__ import annotations

from enum import IntEnum
from ipaddress import IPv4Address

#: 'QLA1' in ASCII, the HARDWARE_VERSION of a QLA board.
QLA1_HARDWARE_VERSION = 0x514C4131
#: Motor channels of a QLA (M = E = 4 in the real-time block formulas).
CHANNELS = 4
#: The 4-bit field the host and the firmware use for board ids.
MAX_BOARD_ID = 15

#: The register index is offset bits 15..0.
REGISTER_INDEX_MASK = 0xFFFF
SPACE_SHIFT = 12
#: Block transfers step bits 11..0 and keep the space nibble.
BLOCK_INDEX_MASK = 0x0FFF


class Space(IntEnum):
    """Address spaces, selected by offset bits 15..12."""

    MAIN = 0x0
    HUB = 0x1
    PROM = 0x2
    PROM_QLA = 0x3
    ETH = 0x4
    FIREWIRE = 0x5
    DALLAS = 0x6
    DATA_BUFFER = 0x7
    WAVEFORM = 0x8
    MOTOR_CONTROL = 0x9
    ESPM = 0xA
    BOARD_SPECIFIC = 0xB


class BoardRegister(IntEnum):
    """Board registers (MAIN space, channel 0)."""

    STATUS = 0
    FW_PHY_REQ = 1
    FW_PHY_RESP = 2
    WATCHDOG = 3
    HARDWARE_VERSION = 4
    TEMPERATURE = 5
    DIGITAL_OUTPUT = 6
    FIRMWARE_VERSION = 7
    PROM_STATUS = 8
    PROM_RESULT = 9
    DIGITAL_INPUT = 10
    IP_ADDRESS = 11
    ETH_STATUS = 12
    DALLAS_STATUS = 13
    IO_EXPANDER = 14
    GIT_DESCRIPTION = 15


class ChannelRegister(IntEnum):
    """Channel registers: offset = (channel << 4) | register, channel 1..4."""

    ADC = 0
    DAC = 1
    ENCODER_PRELOAD = 4
    ENCODER_POSITION = 5
    ENCODER_PERIOD = 6
    ENCODER_QTR1 = 7
    DOUT_CONTROL = 8
    ENCODER_QTR5 = 9
    ENCODER_RUNNING = 10
    MOTOR_CONFIG = 11
    MOTOR_STATUS = 12


# -- STATUS (register 0) ----------------------------------------------------------------

STATUS_CHANNELS_SHIFT = 28
STATUS_BOARD_ID_SHIFT = 24
STATUS_WATCHDOG_TIMEOUT = 1 << 23
STATUS_MOTOR_VOLTAGE_GOOD = 1 << 19
STATUS_POWER_ENABLE = 1 << 18
STATUS_RELAY_FEEDBACK = 1 << 17
STATUS_RELAY_ON = 1 << 16
STATUS_AMP_ON_SHIFT = 8
AMP_BITS = (1 << CHANNELS) - 1

# Writes to STATUS are commands: a "mask" bit says which "value" bit to obey.
COMMAND_AMP_MASK_SHIFT = 8  # bits 11..8 mask bits 3..0 (amplifier enables)
COMMAND_RELAY_MASK = 1 << 17
COMMAND_RELAY_VALUE = 1 << 16
COMMAND_POWER_MASK = 1 << 19
COMMAND_POWER_VALUE = 1 << 18
COMMAND_REBOOT_MASK = 1 << 21
COMMAND_REBOOT_VALUE = 1 << 20

# -- ETH_STATUS (register 12): FPGA generation in bits 31..30 ---------------------------

#: FPGA V1 has no Ethernet: the register reads as unmapped (0).
ETH_STATUS_V1 = 0x00000000
#: V2 is recognised by bit 31 alone.
ETH_STATUS_V2 = 0x80000000
#: V3 (bits 31..30 = 01), 125 MHz and 200 MHz clocks OK, UDP mode.
ETH_STATUS_V3 = 0x40B00000
ETH_STATUS_BY_FPGA_VERSION = {1: ETH_STATUS_V1, 2: ETH_STATUS_V2, 3: ETH_STATUS_V3}

# -- WATCHDOG (register 3) --------------------------------------------------------------

#: The watchdog counts ticks of sysclk / 256 (5.208 us at 49.152 MHz).
WATCHDOG_TICKS_PER_COUNT = 256
#: Power-up period: 0x1680 counts = 30 ms.
WATCHDOG_DEFAULT_PERIOD = 0x1680
WATCHDOG_PERIOD_MASK = 0xFFFF
WATCHDOG_LED_MODE = 1 << 31

# -- channel register bits --------------------------------------------------------------

DAC_VALID = 1 << 31
DAC_ENABLE_MASK = 1 << 29  # Rev 8+: bit 28 sets the amplifier enable
DAC_ENABLE = 1 << 28
DAC_VOLTAGE_MODE = 1 << 24
DAC_VALUE_MASK = 0xFFFF
DAC_BOARD_ID_SHIFT = 24  # Rev 7 real-time writes carry the board id in bits 27..24
DAC_MIDRANGE = 0x8000
ENCODER_MIDRANGE = 0x800000
ENCODER_POSITION_MASK = 0xFFFFFF
MOTOR_CONFIG_SET_LIMIT = 1 << 24
MOTOR_CONFIG_SET_DELAY = 1 << 25
MOTOR_CONFIG_CURRENT_AVAILABLE = 1 << 24
MOTOR_STATUS_AMP_ON = 1 << 29
MOTOR_STATUS_ENABLE_REQUESTED = 1 << 28

# -- hub space --------------------------------------------------------------------------

HUB_MEMORY_BASE = 0x1000
HUB_MEMORY_QUADLETS = 512
HUB_QUERY = 0x1800
HUB_LAST_WRITE = 0x1801
HUB_QUADLETS_WRITTEN = 0x1802
HUB_BOARD_INFO = 0x1803

#: The FireWire host's broadcast write: a block write to node 0 here, which every board
#: takes (offset bits 15..0 are 0: the real-time write block).
FAKE_BROADCAST_OFFSET = 0xFFFF_FFFF_0000
#: Where the FireWire host sends the broadcast query (a quadlet write to node 0) when no
#: board has firmware 7 or later; from 7 on it uses 0x1800.
OLD_QUERY_OFFSET = 0xFFFF_FFFF_000F
OLD_QUERY_LAST_FIRMWARE = 6

# -- PROM spaces (fw1394.boards.qla1.prom) ---------------------------------------------

#: The configuration PROM's page buffer (firmware 4 on).
PROM_BUFFER_BASE = 0x2000
#: The QLA PROM: command, result, 16-quadlet buffer.
QLA_PROM_COMMAND = 0x3000
QLA_PROM_RESULT = 0x3002
QLA_PROM_BUFFER = 0x3100

#: IP_ADDR value meaning "no address assigned".
IP_UNASSIGNED = 0xFFFFFFFF


def ip_to_register(address: str) -> int:
    """IP_ADDR encoding: first octet in bits 7..0, last octet in bits 31..24."""
    return int.from_bytes(IPv4Address(address).packed, "little")


def ip_from_register(value: int) -> str:
    """Inverse of :func:`ip_to_register`."""
    return str(IPv4Address(value.to_bytes(4, "little")))
