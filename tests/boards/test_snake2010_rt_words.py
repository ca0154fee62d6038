"""The real-time block read keeps each channel's words between motions: still the registers.

A snake2010 board keeps the ADC, encoder and period words of its real-time
block until the motor moves or a register changes, builds them in one pass,
and keeps the motor's latest regime for the current sample. Whatever the host
does in between (amplifiers on and off, motor commands, current limits, pot
gain and mode, encoder preloads, watchdog timeouts, time passing), every word
of the block must equal what a quadlet read of the same register returns at
the same moment, and what the register layouts make of the motor's state at
that moment (worked out here, the current decided afresh).
"""

from __future__ import annotations

import math
from typing import Any

from hypothesis import example, given, settings
from hypothesis import strategies as st

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.channel import Channel
from fw1394.boards.snake2010.physics import UNPOWERED, Drive, MotorAxis
from fw1394.boards.snake2010.spec import (
    WIPER_MAX,
    PotCommand,
    current_feedback_gain,
    pot_frame,
    rt_adc_index,
    rt_encoder_index,
    rt_period_index,
)

ADC, DAC, POT_CONTROL, PRELOAD, ENCODER, PERIOD = 0, 1, 2, 4, 5, 6
STATUS, WATCHDOG = 0, 3
VALID = 1 << 31
CHANNELS = 7
SECOND = 49_152_000


def to_a_hard_stop(command: int) -> list[tuple[Any, ...]]:
    """Channel 1 driven hard for seconds: its current and pot samples reach an end of the ADC.

    Full current limit and feedback gain put the current sample past one end;
    the motor then runs into a hard stop, which puts the pot sample at that end.
    """
    return [
        ("status", 0x7F, 0x7F),
        ("pot", 1, PotCommand.WRITE_WIPER, WIPER_MAX),
        ("dac", 1, True, 0xFFFF, True),
        ("dac", 1, False, command, True),
        ("time", 200_000),
        ("time", 3 * SECOND),
    ]


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
    st.tuples(
        st.just("pot"),
        st.integers(1, CHANNELS),
        st.sampled_from([PotCommand.WRITE_WIPER, PotCommand.WRITE_OUTPUTS]),
        st.integers(0, WIPER_MAX),
    ),
    st.tuples(st.just("watchdog"), st.integers(0, 40)),
    st.tuples(st.just("time"), st.one_of(st.integers(0, 200_000), st.integers(0, 3 * SECOND))),
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
    elif kind == "pot":
        _, channel, command, data = step
        board.write_quadlet(channel << 4 | POT_CONTROL, pot_frame(command, data=data))
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


def _adc_half(volts: float) -> int:
    # 14 bits over 0..2.5 V, reported relative to 1.25 V, clipped at both ends.
    code = math.floor(volts / 2.5 * (1 << 14)) - 8192
    return min(max(code, -8192), 8191) & 0xFFFF


def _drive_from_registers(board: Snake2010Board, channel: Channel) -> Drive:
    """What the amplifier gets from the status, DAC and pot registers."""
    n, constants = channel.number, channel.constants
    status = board.read_quadlet(STATUS)
    if not status >> (n - 1) & 1 or status >> (16 + n - 1) & 1:  # enabled, no fault
        return UNPOWERED
    dac = board.read_quadlet(n << 4 | DAC)
    command_volts = ((dac & 0xFFFF) - 0x8000) * 2.5 / 65536
    limit = (dac >> 16) / 65536 * constants.current_limit_full_scale_amps
    compensation = 0.0
    if channel.pot.outputs & 1:  # O1: speed mode, the current fed back
        gain = current_feedback_gain(channel.pot.wiper)
        compensation = constants.compensation_gain * gain * constants.sense_ohms
    return Drive(True, constants.bridge_gain * command_volts, limit, compensation)


def _words_from_state(channel: Channel, count_at_preload: int) -> tuple[int, int, int]:
    """The channel's ADC, encoder and period words, worked out from the spec and its motor."""
    motor, constants = channel.motor, channel.constants
    pot_volts = 2.5 * (motor.position_mm / constants.travel_mm)
    fresh = MotorAxis(constants)  # decides the current afresh from the speed
    fresh.velocity_rad_s = motor.velocity_rad_s
    sense_gain = current_feedback_gain(channel.pot.wiper) * constants.sense_ohms
    current_fraction = 0.5 + sense_gain * fresh.current_amps(channel.drive) / 2.5
    adc = _adc_half(pot_volts) << 16 | _adc_half(2.5 * current_fraction)
    per_rad = constants.encoder_counts_per_rev / (2 * math.pi)

    def count(angle: float) -> int:
        return channel.preload + math.floor(angle * per_rad) - count_at_preload

    overflow = count(motor.lowest_angle_rad) < 0 or count(motor.highest_angle_rad) >= 1 << 24
    encoder = count(motor.angle_rad) & 0xFFFFFF | overflow << 24
    if motor.last_direction == 0:
        return adc, encoder, 0
    edges_per_second = abs(motor.velocity_rad_s) * per_rad
    clocks = 0x7FFF
    if edges_per_second * 0x7FFF > 768_000:
        clocks = math.floor(768_000 / edges_per_second)
    return adc, encoder, motor.last_direction * clocks & 0xFFFF


@settings(max_examples=150, deadline=None)
@given(st.lists(steps, max_size=30))
@example(to_a_hard_stop(0xFFFF))
@example(to_a_hard_stop(0x0000))
def test_realtime_block_words_follow_the_motors(script: list[Any]) -> None:
    board = Snake2010Board(board_id=1)
    counts_at_preload = [0] * CHANNELS
    now = 0
    for step in script:
        now = _apply(board, step, now)
        if step[0] == "preload":
            angle = board.channels[step[1] - 1].motor.angle_rad
            counts_at_preload[step[1] - 1] = math.floor(angle * 2048 / (2 * math.pi))
        block = board.read_block(0, 4 * (4 + 4 * CHANNELS))
        words = [int.from_bytes(block[i : i + 4], "big") for i in range(0, len(block), 4)]
        for channel, at_preload in zip(board.channels, counts_at_preload, strict=True):
            assert channel.drive == _drive_from_registers(board, channel)
            n = channel.number
            got = (
                words[rt_adc_index(n)],
                words[rt_encoder_index(n, CHANNELS)],
                words[rt_period_index(n, CHANNELS)],
            )
            assert got == _words_from_state(channel, at_preload)
