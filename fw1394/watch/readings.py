"""What one refresh learns about a snake2010 board, decoded but not yet formatted.

A :class:`BoardReading` is built from the latched data of a host-library
:class:`~fw1394.host.Board` plus the few registers the real-time block does
not carry (DAC read-back, watchdog period) and the pot settings read through
the handshake. Building it does no I/O, so the view can be tested on boards
in-process.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

from fw1394.boards.snake2010.spec import (
    DAC_CODE_MASK,
    DAC_READ_LIMIT_SHIFT,
    OUTPUT_O1,
    STATUS_BOARD_ID_MASK,
    STATUS_BOARD_ID_SHIFT,
    STATUS_ENABLES_MASK,
    STATUS_FAULT_MASK,
    STATUS_FAULT_SHIFT,
    STATUS_WATCHDOG_TIMEOUT,
)
from fw1394.host import Board


@dataclass(frozen=True)
class StatusBits:
    """Table 2 of the thesis, field by field, for a board of ``len(enables)`` channels."""

    board_id: int
    watchdog_timeout: bool
    faults: tuple[bool, ...]
    enables: tuple[bool, ...]

    @property
    def leds(self) -> tuple[bool, ...]:
        """LED per channel: lit when the amplifier is enabled and its fault line quiet.

        The LEDs are not reachable over the bus; this is the rule the board
        drives them by (thesis 5.3, 6.3), applied to the status word.
        """
        return tuple(on and not fault for on, fault in zip(self.enables, self.faults, strict=True))


def decode_status(word: int, channels: int) -> StatusBits:
    """Split a status word into its fields, keeping the bits of ``channels`` channels."""
    faults = (word >> STATUS_FAULT_SHIFT) & STATUS_FAULT_MASK
    enables = word & STATUS_ENABLES_MASK
    return StatusBits(
        board_id=(word >> STATUS_BOARD_ID_SHIFT) & STATUS_BOARD_ID_MASK,
        watchdog_timeout=bool(word & STATUS_WATCHDOG_TIMEOUT),
        faults=tuple(bool(faults >> axis & 1) for axis in range(channels)),
        enables=tuple(bool(enables >> axis & 1) for axis in range(channels)),
    )


@dataclass(frozen=True)
class PotSettings:
    """Digital-pot state of one channel, read through the pot handshake."""

    wiper: int
    switches: int

    @property
    def speed_mode(self) -> bool:
        """Output O1 high selects speed control, low torque control."""
        return bool(self.switches & OUTPUT_O1)


@dataclass(frozen=True)
class ChannelReading:
    """One channel's inputs in host-API units (see docs/boards/snake2010.md)."""

    axis: int  # host-library axis, from 0
    encoder: int  # 24-bit count
    overflow: bool
    period: int  # signed 768 kHz clocks between encoder edges
    pot: int  # ADC API value 0..16383
    current: int  # ADC API value 0..16383
    dac: int  # motor command read back, 0..65535
    current_limit: int  # current-limit DAC read back, 0..65535
    enabled: bool
    fault: bool
    pot_settings: PotSettings | None

    @property
    def channel(self) -> int:
        """Channel number as the thesis and the register map count: from 1."""
        return self.axis + 1

    @property
    def led(self) -> bool:
        return self.enabled and not self.fault


@dataclass(frozen=True)
class BoardReading:
    """Everything one refresh shows about one board."""

    node: int
    kind: str
    status: StatusBits
    status_word: int
    timestamp: int  # 49.152 MHz clocks since the previous real-time block read
    watchdog_period: int  # 192 kHz counts; 0 = watchdog off
    channels: tuple[ChannelReading, ...]


def split_dac_word(word: int) -> tuple[int, int]:
    """(motor command, current limit) from a DAC register read."""
    return word & DAC_CODE_MASK, (word >> DAC_READ_LIMIT_SHIFT) & DAC_CODE_MASK


def reading_of(
    board: Board,
    kind: str,
    dac_words: Sequence[int],
    watchdog_period: int,
    pot_settings: Sequence[PotSettings | None],
) -> BoardReading:
    """Decode what ``board`` latched last, with the DAC words read beside it."""
    count = board.num_axes
    if len(dac_words) != count or len(pot_settings) != count:
        raise ValueError(f"need one DAC word and pot setting per axis ({count})")
    status = decode_status(board.get_status(), count)
    channels = []
    for axis in range(count):
        command, limit = split_dac_word(dac_words[axis])
        channels.append(
            ChannelReading(
                axis=axis,
                encoder=board.get_encoder_position(axis),
                overflow=board.get_encoder_overflow(axis),
                period=board.get_encoder_velocity(axis),
                pot=board.get_analog_position(axis),
                current=board.get_motor_current(axis),
                dac=command,
                current_limit=limit,
                enabled=status.enables[axis],
                fault=status.faults[axis],
                pot_settings=pot_settings[axis],
            )
        )
    return BoardReading(
        node=board.node,
        kind=kind,
        status=status,
        status_word=board.get_status(),
        timestamp=board.get_timestamp(),
        watchdog_period=watchdog_period,
        channels=tuple(channels),
    )
