"""Host view of the snake board's real-time blocks (thesis section 6.4).

One block read at offset 0 latches every input of a node; one block write
at offset 0 carries every motor command, each quadlet with a valid bit so
the block keeps its fixed size when only some axes change. Layouts are in
docs/boards/snake2010.md.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence
from dataclasses import dataclass

from fw1394.boards.snake2010.spec import (
    DAC_CODE_MASK,
    VALID_BIT,
    RtRead,
    rt_adc_index,
    rt_encoder_index,
    rt_frequency_index,
    rt_period_index,
    rt_read_quadlets,
)


class BlockSizeError(ValueError):
    """A real-time block had the wrong number of bytes."""


@dataclass(frozen=True)
class RealtimeInputs:
    """Raw words of one real-time block read; tuples are indexed by axis."""

    timestamp: int
    status: int
    adc: tuple[int, ...]
    encoder: tuple[int, ...]
    period: tuple[int, ...]
    frequency: tuple[int, ...]

    @classmethod
    def empty(cls, channels: int) -> RealtimeInputs:
        """All-zero inputs, what a board shows before its first latch."""
        zeros = (0,) * channels
        return cls(0, 0, zeros, zeros, zeros, zeros)


def realtime_read_length(channels: int) -> int:
    """Bytes to request for the real-time block of a ``channels`` board."""
    return 4 * rt_read_quadlets(channels)


def parse_realtime_block(data: bytes, channels: int) -> RealtimeInputs:
    """Split a real-time block read into its fields."""
    expected = realtime_read_length(channels)
    if len(data) != expected:
        raise BlockSizeError(f"real-time block of {len(data)} bytes, expected {expected}")
    words = struct.unpack(f">{expected // 4}I", data)
    numbers = range(1, channels + 1)
    return RealtimeInputs(
        timestamp=words[RtRead.TIMESTAMP],
        status=words[RtRead.STATUS],
        adc=tuple(words[rt_adc_index(n)] for n in numbers),
        encoder=tuple(words[rt_encoder_index(n, channels)] for n in numbers),
        period=tuple(words[rt_period_index(n, channels)] for n in numbers),
        frequency=tuple(words[rt_frequency_index(n, channels)] for n in numbers),
    )


def build_realtime_write(commands: Sequence[int | None]) -> bytes:
    """Real-time write block: one DAC quadlet per axis, None = not valid."""
    words = [0 if code is None else VALID_BIT | (code & DAC_CODE_MASK) for code in commands]
    return struct.pack(f">{len(words)}I", *words)
