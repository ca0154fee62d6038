"""QLA STATUS (register 0): a relay command (bit 17 mask, bit 16 value) shows in bit 16
and the relay feedback bit 17, and leaves the amplifier bits 11:0 alone (the JHU
register map's STATUS read layout, BoardRegs-QLA.v)."""

from __future__ import annotations

from fw1394.boards import make_board

STATUS = 0
RELAY_MASK, RELAY_VALUE = 1 << 17, 1 << 16


def test_the_relay_command_sets_bits_16_and_17_only() -> None:
    board = make_board("qla1", board_id=1)
    before = board.read_quadlet(STATUS)
    board.write_quadlet(STATUS, RELAY_MASK | RELAY_VALUE)
    after = board.read_quadlet(STATUS)
    assert after & (RELAY_MASK | RELAY_VALUE) == RELAY_MASK | RELAY_VALUE
    assert after & 0xFFF == before & 0xFFF
    board.write_quadlet(STATUS, RELAY_MASK)
    assert board.read_quadlet(STATUS) == before
