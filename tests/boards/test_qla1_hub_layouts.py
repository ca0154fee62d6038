"""Hub memory per firmware revision, byte for byte against the layouts of the JHU notes.

jhu-eth1394.md §2.10 (and §4.5 for the real-time block inside each slot):

* Rev 4-6: one 17-quadlet slot for every board number 0-15; header = full
  16-bit sequence in bits 31..16 (no update time); then 16 data quadlets;
  slots of boards not in the round are skipped by the host (here: zero);
  272 quadlets in all, no closing timing quadlet;
* Rev 7: packed 29-quadlet blocks (1 header + 28), header = full 16-bit
  sequence in 31..16 and a 14-bit update time in 15..0, then one timing
  quadlet;
* Rev 8+: packed blocks, header = size 31..24, low sequence byte 23..16,
  mismatch bit 15, update time 14..0; then one timing quadlet.

The expected images are built here from those tables and from values each
board was given (encoder preloads), never from the hub code under test.
"""

from __future__ import annotations

from collections.abc import Sequence

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.qla1.board import Qla1Board

QUERY, HUB, BROADCAST_OFFSET = 0x1800, 0x1000, 0xFFFF_FF00_1000
ENC_LOAD = 4
#: Real-time block positions of the spec's table (§4.5): timestamp 0, status 1,
#: digital input 2, temperature 3, ADC 4-7, encoder position 8-11.
RT_STATUS, RT_POSITION = 1, 8


def words(data: bytes) -> list[int]:
    return [int.from_bytes(data[n : n + 4], "big") for n in range(0, len(data), 4)]


def pack(values: Sequence[int]) -> bytes:
    return b"".join(value.to_bytes(4, "big") for value in values)


def positions(board_id: int) -> list[int]:
    """Encoder values this test preloads into board ``board_id`` (distinct per board)."""
    return [0x100000 * (board_id + 1) + channel for channel in range(1, 5)]


def make_board(board_id: int, firmware: int) -> Qla1Board:
    board = Qla1Board(board_id=board_id, firmware=firmware)
    for channel, value in enumerate(positions(board_id), start=1):
        board.write_quadlet(channel << 4 | ENC_LOAD, value)
    return board


def run_round(
    hub: Qla1Board, others: Sequence[Qla1Board], sequence: int, *, gaps: Sequence[int] = ()
) -> None:
    """A broadcast query naming every board, each other board's broadcast reaching the hub
    (after ``gaps[n]`` ticks), in the order given."""
    mask = sum(1 << board.board_id for board in (hub, *others))
    for board in (hub, *others):
        board.write_quadlet(QUERY, sequence << 16 | mask)
    for n, board in enumerate(others):
        if n < len(gaps):
            hub.set_time(hub.now + gaps[n])
        block = words(board.read_block(0, 4 * board.rt_read_quadlets))
        # A board's broadcast (§4.8): {sequence 31..16, quadlet count}, then its block.
        hub.write_block(BROADCAST_OFFSET, pack([sequence << 16 | len(block), *block]))


def check_block(data: Sequence[int], board_id: int) -> None:
    """The start of board ``board_id``'s real-time block (§4.5) in ``data``."""
    status = data[RT_STATUS]
    assert status >> 28 == 4, "4 axes"
    assert status >> 24 & 0xF == board_id
    assert [value & 0xFFFFFF for value in data[RT_POSITION : RT_POSITION + 4]] == positions(
        board_id
    )


@pytest.mark.parametrize("firmware", [4, 5, 6])
def test_rev4_6_slot_per_board_number_with_a_gap(firmware: int) -> None:
    ids = [1, 3, 4, 9]  # gaps: board numbers 0, 2, 5-8 and 10-15 are not in the rack
    hub, *others = [make_board(board_id, firmware) for board_id in ids]
    sequence = 0x2345
    run_round(hub, others, sequence)
    memory = words(hub.read_block(HUB, 4 * 16 * 17))
    assert len(memory) == 272
    for number in range(16):
        slot = memory[17 * number : 17 * number + 17]
        if number not in ids:
            assert slot == [0] * 17, f"board number {number} is not in the rack"
            continue
        assert slot[0] == sequence << 16, "full sequence, no update time"
        check_block(slot[1:], number)
    # Nothing follows the 16 slots: no timing quadlet in this revision.
    assert hub.read_quadlet(HUB + 272) == 0


def test_rev7_packed_29_quadlet_blocks_full_sequence_and_update_time() -> None:
    ids = [0, 2, 3]
    hub, *others = [make_board(board_id, 7) for board_id in ids]
    sequence = 0x1234  # above 255: the whole 16 bits must be there
    # Board 2 reports 5 ticks after the query, board 3 0x4000 + 7 ticks after that:
    # the 14-bit update time wraps at 0x4000.
    run_round(hub, others, sequence, gaps=[5, 0x4000 + 7 - 5 + 5])
    memory = words(hub.read_block(HUB, 4 * (29 * 3 + 1)))
    for n, board_id in enumerate(ids):
        block = memory[29 * n : 29 * n + 29]
        assert block[0] >> 16 == sequence
        check_block(block[1:], board_id)
    assert memory[0] & 0xFFFF == 0, "the hub's own block, taken at the query"
    assert memory[29] & 0xFFFF == 5
    assert memory[58] & 0xFFFF == (5 + 0x4000 + 7) & 0x3FFF
    timing = memory[87]
    assert timing >> 16 == (5 + 0x4000 + 7) & 0x3FFF, "last update, 14 bits"
    assert timing != 0
    assert hub.read_quadlet(HUB + 88) == 0, "nothing after the timing quadlet"


@pytest.mark.parametrize("firmware", [8, 9, 10])
def test_rev8_packed_blocks_sized_by_their_header(firmware: int) -> None:
    ids = [0, 1]
    hub, *others = [make_board(board_id, firmware) for board_id in ids]
    sequence = 0x0305
    run_round(hub, others, sequence, gaps=[10])
    hub.set_time(hub.now + 20)
    memory = words(hub.read_block(HUB, 4 * (2 * 33 + 1)))
    for n, board_id in enumerate(ids):
        block = memory[33 * n : 33 * n + 33]
        assert block[0] >> 24 == 33
        assert block[0] >> 16 & 0xFF == 0x05, "low byte of the sequence only"
        assert not block[0] & 0x8000
        check_block(block[1:], board_id)
    assert memory[33] & 0x7FFF == 10
    # Closing quadlet: {last update, read}, ticks since the query.
    assert memory[66] == 10 << 16 | 30


def test_hub_image_is_in_board_order_not_arrival_order() -> None:
    ids = [0, 5, 2, 7]
    hub, *others = [make_board(board_id, 8) for board_id in ids]
    run_round(hub, others, 9)  # boards 5, 2 and 7 report in that order
    memory = words(hub.read_block(HUB, 4 * (4 * 33 + 1)))
    found = [memory[33 * n + 2] >> 24 & 0xF for n in range(4)]
    assert found == [0, 2, 5, 7]


def test_rev7_hub_sequence_mismatch_keeps_the_boards_own_sequence() -> None:
    hub, other = make_board(0, 7), make_board(1, 7)
    mask = 0b11
    hub.write_quadlet(QUERY, 0x0101 << 16 | mask)
    other.write_quadlet(QUERY, 0x0100 << 16 | mask)  # a stale round on board 1
    block = words(other.read_block(0, 4 * 28))
    hub.write_block(BROADCAST_OFFSET, pack([0x0100 << 16 | 28, *block]))
    memory = words(hub.read_block(HUB, 4 * 59))
    assert memory[0] >> 16 == 0x0101 and memory[29] >> 16 == 0x0100


@pytest.mark.parametrize("firmware", [5, 7, 9])
def test_a_block_read_of_hub_space_equals_its_quadlet_reads(firmware: int) -> None:
    hub, *others = [make_board(board_id, firmware) for board_id in (0, 3, 6)]
    run_round(hub, others, 0x0456, gaps=[3, 4])
    start, count = HUB + 20, 120
    block = words(hub.read_block(start, 4 * count))
    assert block == [hub.read_quadlet(start + n) for n in range(count)]
    tail = words(hub.read_block(0x17F0, 4 * 24))  # past hub memory into the query registers
    assert tail == [hub.read_quadlet(0x17F0 + n) for n in range(24)]


@settings(max_examples=150, deadline=None)
@given(
    st.sampled_from([5, 7, 9]),
    st.integers(0, 0xFFF),
    st.integers(1, 700),
    st.sampled_from([0, 0xFFFF_0000_0000, 0x1_0000]),
)
def test_any_hub_space_block_read_equals_its_quadlet_reads(
    firmware: int, index: int, count: int, upper: int
) -> None:
    # A block steps bits 11..0 and keeps the space nibble: past 0x1FFF it wraps to 0x1000.
    hub, *others = [make_board(board_id, firmware) for board_id in (0, 3, 6)]
    run_round(hub, others, 0x0123, gaps=[2, 5])
    start = upper | HUB | index
    block = words(hub.read_block(start, 4 * count))
    steps = [upper | HUB | (index + n) & 0xFFF for n in range(count)]
    assert block == [hub.read_quadlet(offset) for offset in steps]
