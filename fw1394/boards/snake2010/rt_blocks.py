"""Host view of the snake board's real-time blocks (thesis section 6.4).

One block read at offset 0 latches every input of a node; one block write
at offset 0 carries every motor command, each quadlet with a valid bit so
the block keeps its fixed size when only some axes change. Layouts are in
docs/boards/snake2010.md.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable, Sequence
from typing import NamedTuple

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
from fw1394.errors import UsageError


class BlockSizeError(UsageError):
    """A real-time block had the wrong number of bytes."""


class RealtimeInputs(NamedTuple):
    """Raw words of one real-time block read; tuples are indexed by axis.

    A named tuple: the host makes one per board and servo cycle.
    """

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
    shape, fields = _layout(channels)
    if len(data) != shape.size:
        raise BlockSizeError(f"real-time block of {len(data)} bytes, expected {shape.size}")
    words = shape.unpack(data)
    adc, encoder, period, frequency = fields
    timestamp, status = words[_TIMESTAMP], words[_STATUS]
    return RealtimeInputs(
        timestamp, status, words[adc], words[encoder], words[period], words[frequency]
    )


_TIMESTAMP, _STATUS = int(RtRead.TIMESTAMP), int(RtRead.STATUS)


@functools.cache
def _layout(channels: int) -> tuple[struct.Struct, tuple[slice, ...]]:
    """The block's struct, and the slice of its words holding each per-axis field.

    Read off the spec's index functions: the words of one field are consecutive
    (checked here), so one slice takes a field for every axis.
    """
    fields: tuple[Callable[[int], int], ...] = (
        rt_adc_index,
        lambda n: rt_encoder_index(n, channels),
        lambda n: rt_period_index(n, channels),
        lambda n: rt_frequency_index(n, channels),
    )
    slices = []
    for index in fields:
        first = index(1)
        if [index(n) for n in range(1, channels + 1)] != list(range(first, first + channels)):
            raise AssertionError("a real-time field's words are not consecutive")
        slices.append(slice(first, first + channels))
    return struct.Struct(f">{rt_read_quadlets(channels)}I"), tuple(slices)


def build_realtime_write(commands: Sequence[int | None]) -> bytes:
    """Real-time write block: one DAC quadlet per axis, None = not valid."""
    words = [0 if code is None else VALID_BIT | (code & DAC_CODE_MASK) for code in commands]
    return struct.pack(f">{len(words)}I", *words)
