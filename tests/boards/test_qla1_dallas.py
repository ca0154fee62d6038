"""The DS2505 1-wire memory as ``instrument`` reads it (jhu-eth1394.md §4.10).

The sequence is the host library's: control ``address << 16 | 2`` to register 13,
poll register 13 until ``status & 0x20F0 == 0``, check ``status & 0xFF00000F ==
0x0B00000B`` (family code DS2505, DOUT bidirectional, reset answered, enabled),
block-read 256 bytes at 0x6000, then control ``3`` and read again, 8 times for
the chip's 2 KiB.
"""

from __future__ import annotations

import pytest

from fw1394.boards.qla1.board import Qla1Board

DALLAS, BUFFER = 13, 0x6000


def wait_idle(board: Qla1Board) -> int:
    for _ in range(2000):
        status = board.read_quadlet(DALLAS)
        if status & 0x20F0 == 0:
            return status
    raise AssertionError("the 1-wire interface stays busy")


def read_memory(board: Qla1Board, address: int, count: int) -> bytes:
    board.write_quadlet(DALLAS, address << 16 | 2)
    status = wait_idle(board)
    assert status & 0xFF00000F == 0x0B00000B
    data = board.read_block(BUFFER, 256)
    while len(data) < count:
        board.write_quadlet(DALLAS, 3)
        wait_idle(board)
        data += board.read_block(BUFFER, 256)
    return data[:count]


def test_instrument_reads_the_whole_memory() -> None:
    board = Qla1Board(board_id=0, firmware=8)
    contents = bytes(range(256)) * 8
    board.dallas.memory = contents
    assert read_memory(board, 0, 2048) == contents
    status = board.read_quadlet(DALLAS)
    assert status & 1 == 1, "interface enabled"
    assert status >> 1 & 0b11 == 1, "the chip answered the reset"
    assert status >> 24 == 0x0B, "DS2505 family code"
    assert status >> 16 & 0xFF, "a rise time"


def test_reads_start_where_asked_and_wrap_at_2k() -> None:
    board = Qla1Board(board_id=0, firmware=7)
    board.dallas.memory = bytes(n % 251 for n in range(2048))
    assert read_memory(board, 0x700, 512) == bytes(n % 251 for n in range(0x700, 0x800)) + bytes(
        n % 251 for n in range(0, 0x100)
    )


def test_default_contents_and_power_up_status() -> None:
    board = Qla1Board(board_id=0, firmware=9)
    assert board.read_quadlet(DALLAS) & 0xF0 == 0
    assert read_memory(board, 0, 16).startswith(b"fw1394 ")


@pytest.mark.parametrize("firmware", [4, 6])
def test_nothing_before_firmware_7(firmware: int) -> None:
    board = Qla1Board(board_id=0, firmware=firmware)
    board.write_quadlet(DALLAS, 2)
    assert board.read_quadlet(DALLAS) == 0
    assert board.read_block(BUFFER, 8) == bytes(8)
