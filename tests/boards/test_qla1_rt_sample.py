"""A board keeps the last sample's block after its timestamp while its inputs stay the same.

Whatever happens to a board between two samples (register writes, real-time block
writes, STATUS commands and reboots, the watchdog running out), its next real-time
block must be the one made from scratch from the board's state at that moment.
"""

from __future__ import annotations

import struct
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.qla1.board import Qla1Board

DAC_VALID = 1 << 31
#: STATUS commands: relay, power, amplifier enables, a reboot (bits 21/20).
STATUS_COMMANDS = [0, 0x000A_0000, 0x000F_0F0F, 0x0003_0000, 0x000C_0000, 0x0000_0F00, 0x0030_0000]

quadlet = st.integers(0, 0xFFFFFFFF)
operations = st.one_of(
    st.tuples(st.just("write"), st.integers(0, 0x4F), quadlet),
    st.tuples(st.just("write"), st.just(0), st.sampled_from(STATUS_COMMANDS)),
    st.tuples(st.just("digout"), st.integers(0, 0xFFF)),
    st.tuples(st.just("rt"), st.lists(st.integers(0, 0xFFFF), min_size=4, max_size=4), quadlet),
    st.tuples(st.just("time"), st.integers(0, 5_000_000)),
    st.tuples(st.just("sample"), st.none()),
)


def fresh_block(board: Qla1Board) -> list[int]:
    """The block a board that never sampled before would report now (timestamp aside)."""
    return list(board._sample_tail())


@settings(max_examples=150, deadline=None)
@given(st.sampled_from([4, 6, 7, 8, 9]), st.lists(operations, min_size=1, max_size=30))
def test_a_kept_sample_is_the_sample_made_now(firmware: int, script: list[tuple[Any, ...]]) -> None:
    board = Qla1Board(board_id=3, firmware=firmware)
    for kind, *detail in script:
        if kind == "write":
            board.write_quadlet(*detail)
        elif kind == "digout":
            board.write_quadlet(0x6, detail[0])
        elif kind == "rt":
            dacs, control = detail
            words = [3 << 24 | DAC_VALID | value for value in dacs]
            if firmware >= 8:
                words = [3 << 8 | 6, *words, control]
            elif firmware == 7:
                words.append(control)
            board.write_block(0, struct.pack(f">{len(words)}I", *words))
        elif kind == "time":
            board.set_time(board.now + detail[0])
        block = board._rt_block()
        assert list(block[1:]) == fresh_block(board)
