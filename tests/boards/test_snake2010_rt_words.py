"""The real-time block read keeps each channel's words between motions: still the registers.

A snake2010 board keeps the ADC, encoder and period words of its real-time
block until the motor moves or a register changes. Whatever the host does in
between (amplifiers on and off, motor commands, current limits, encoder
preloads, watchdog timeouts, time passing), every word of the block must equal
what a quadlet read of the same register returns at the same moment, which
computes it afresh.
"""

from __future__ import annotations

from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.spec import rt_adc_index, rt_encoder_index, rt_period_index

ADC, DAC, PRELOAD, ENCODER, PERIOD = 0, 1, 4, 5, 6
STATUS, WATCHDOG = 0, 3
VALID = 1 << 31
CHANNELS = 7

steps = st.one_of(
    st.tuples(st.just("status"), st.integers(0, 0x7F), st.integers(0, 0x7F)),
    st.tuples(
        st.just("dac"),
        st.integers(1, CHANNELS),
        st.booleans(),
        st.integers(0, 0xFFFF),
        st.booleans(),
    ),
    st.tuples(st.just("preload"), st.integers(1, CHANNELS), st.integers(0, 0xFFFFFF)),
    st.tuples(st.just("watchdog"), st.integers(0, 40)),
    st.tuples(st.just("time"), st.integers(0, 200_000)),
    st.tuples(st.just("block"), st.just(0)),
)


def _apply(board: Snake2010Board, step: Any, now: int) -> int:
    kind = step[0]
    if kind == "status":
        board.write_quadlet(STATUS, step[1] << 8 | step[2])
    elif kind == "dac":
        _, channel, limit, code, valid = step
        word = (VALID if valid else 0) | (1 << 16 if limit else 0) | code
        board.write_quadlet(channel << 4 | DAC, word)
    elif kind == "preload":
        board.write_quadlet(step[1] << 4 | PRELOAD, step[2])
    elif kind == "watchdog":
        board.write_quadlet(WATCHDOG, step[1])
    elif kind == "time":
        now += step[1]
        board.set_time(now)
    return now


@settings(max_examples=150, deadline=None)
@given(st.lists(steps, max_size=30))
def test_realtime_block_words_equal_register_reads(script: list[Any]) -> None:
    board = Snake2010Board(board_id=1)
    now = 0
    for step in script:
        now = _apply(board, step, now)
        block = board.read_block(0, 4 * (4 + 4 * CHANNELS))
        words = [int.from_bytes(block[i : i + 4], "big") for i in range(0, len(block), 4)]
        for channel in range(1, CHANNELS + 1):
            assert words[rt_adc_index(channel)] == board.read_quadlet(channel << 4 | ADC)
            encoder = board.read_quadlet(channel << 4 | ENCODER)
            assert words[rt_encoder_index(channel, CHANNELS)] == encoder
            period = board.read_quadlet(channel << 4 | PERIOD)
            assert words[rt_period_index(channel, CHANNELS)] == period
        assert words[1] == board.read_quadlet(STATUS)
