"""The host's real-time block parser against a word-by-word decoding of the spec.

The parser takes each field's words with one slice of a precompiled struct;
the reference here reads every word on its own, at the quadlet index the spec's
``rt_*_index`` functions give, from the bytes as the thesis lays them out (big-endian).
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.boards.snake2010.rt_blocks import (
    BlockSizeError,
    parse_realtime_block,
    realtime_read_length,
)
from fw1394.boards.snake2010.spec import (
    RtRead,
    rt_adc_index,
    rt_encoder_index,
    rt_frequency_index,
    rt_period_index,
)


def _word(data: bytes, index: int) -> int:
    return int.from_bytes(data[4 * index : 4 * index + 4], "big")


@st.composite
def blocks(draw: st.DrawFn) -> tuple[int, bytes]:
    channels = draw(st.integers(1, 7))
    size = realtime_read_length(channels)
    return channels, draw(st.binary(min_size=size, max_size=size))


@given(blocks())
def test_parser_equals_the_word_by_word_decoding(block: tuple[int, bytes]) -> None:
    channels, data = block
    parsed = parse_realtime_block(data, channels)
    numbers = range(1, channels + 1)
    assert parsed.timestamp == _word(data, RtRead.TIMESTAMP)
    assert parsed.status == _word(data, RtRead.STATUS)
    assert parsed.adc == tuple(_word(data, rt_adc_index(n)) for n in numbers)
    assert parsed.encoder == tuple(_word(data, rt_encoder_index(n, channels)) for n in numbers)
    assert parsed.period == tuple(_word(data, rt_period_index(n, channels)) for n in numbers)
    frequency = tuple(_word(data, rt_frequency_index(n, channels)) for n in numbers)
    assert parsed.frequency == frequency


@given(st.integers(1, 7), st.integers(-8, 8).filter(bool))
def test_parser_refuses_a_block_of_another_size(channels: int, extra: int) -> None:
    size = max(0, realtime_read_length(channels) + extra)
    with pytest.raises(BlockSizeError):
        parse_realtime_block(bytes(size), channels)
