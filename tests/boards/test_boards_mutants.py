"""QLA board parts at edges the register tests do not reach.

Facts from jhu-eth1394.md §4: STATUS bits 3:0 are the amplifier enables of axes
1-4 (bit n-1: axis n); the hub's real-time block starts with the 49.152 MHz ticks
since the broadcast query. The PROM instruction codes are the M25P16 data sheet's
(bulk erase 0xC7, sector erase 0xD8, write enable 0x06); an instruction the chip
does not know does nothing.
"""

from __future__ import annotations

from fw1394.boards.qla1.hub import HubBlock, HubState
from fw1394.boards.qla1.prom import ConfigProm
from fw1394.boards.qla1.status import BoardControl

WRITE_ENABLE = 0x06


def test_an_amplifier_request_enables_the_bit_of_its_axis() -> None:
    for axis in (1, 2, 3, 4):
        control = BoardControl(power_enable=True)
        control.request_amp(axis, True)
        assert control.amps_enabled == 1 << (axis - 1)
        control.request_amp(axis, False)
        assert control.amps_enabled == 0


def test_a_kept_block_counts_its_ticks_from_the_query() -> None:
    hub = HubState(board_id=0)
    hub.query(1 << 16 | 0b11, now=1_000)
    made_elsewhere = HubBlock(sequence=1, update_ticks=7, quadlets=(1, 2, 3))
    hub.keep(1, made_elsewhere, now=1_500)
    assert hub.blocks[1].update_ticks == 500
    assert hub.blocks[1].quadlets == (1, 2, 3)


def test_an_instruction_the_prom_does_not_know_erases_nothing() -> None:
    prom = ConfigProm()
    prom.store(0x100, b"\x12\x34")
    for unknown in (0xE0, 0xFF):
        prom.command(WRITE_ENABLE << 24, now=0)
        prom.command(unknown << 24, now=0)
        assert prom.read_bytes(0x100, 2) == b"\x12\x34"
