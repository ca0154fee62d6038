"""QLA digital outputs: a DIGOUT write (register 6) carries a mask in bits 11:8 for the
output bits 3:0, and DIGIN (register 10) shows the outputs in bits 15:12 (the JHU
register map, BoardRegs-QLA.v: DIGOUT ``(mask<<8) | bits``, DIGIN 15:12 dout)."""

from __future__ import annotations

from fw1394.boards import make_board

DIGOUT, DIGIN = 6, 10


def outputs(board_reading: int) -> int:
    return board_reading >> 12 & 0xF


def test_a_digout_write_changes_only_the_masked_outputs() -> None:
    board = make_board("qla1", board_id=2)
    start = outputs(board.read_quadlet(DIGIN))
    board.write_quadlet(DIGOUT, 0b0101 << 8 | 0b1111)
    expected = start & ~0b0101 | 0b0101
    assert outputs(board.read_quadlet(DIGIN)) == expected
    board.write_quadlet(DIGOUT, 0b1010 << 8 | 0b0000)
    expected &= ~0b1010
    assert outputs(board.read_quadlet(DIGIN)) == expected == 0b0101
    board.write_quadlet(DIGOUT, 0b1001 << 8 | 0b1110)
    assert outputs(board.read_quadlet(DIGIN)) == 0b1100
    # No mask bits: nothing changes, whatever the value bits say.
    board.write_quadlet(DIGOUT, 0b1111)
    assert outputs(board.read_quadlet(DIGIN)) == 0b1100
