"""QLA hub memory layout per firmware family, as the JHU host parses it (spec §2.10 and
§4.8): Rev 4-6 a 17-quadlet slot (header + 16) for every board number; Rev 7 packed
blocks of 29 quadlets (header + 28) with the full 16-bit sequence and a 14-bit update
time (below firmware 9); Rev 8+ packed blocks sized by their header, the sequence's
low byte, the update time in bits 14:0 from firmware 9 (14 bits below it), and a
closing quadlet of two 16-bit times."""

from __future__ import annotations

from fw1394.boards.qla1.hub import hub_layout


def test_rev4_to_6_keep_a_slot_per_board_number() -> None:
    for firmware in (4, 5, 6):
        layout = hub_layout(firmware)
        assert layout.slot_per_board_number and layout.data_quadlets == 16
        assert layout.full_sequence and layout.update_time_bits == 0


def test_rev7_packs_fixed_blocks_with_the_full_sequence() -> None:
    layout = hub_layout(7)
    assert not layout.slot_per_board_number and layout.data_quadlets == 28
    assert layout.full_sequence and layout.update_time_bits == 14


def test_rev8_and_later_size_blocks_by_their_header() -> None:
    below_nine, nine = hub_layout(8), hub_layout(9)
    for layout in (below_nine, nine, hub_layout(10)):
        assert not layout.slot_per_board_number and layout.data_quadlets is None
        assert not layout.full_sequence
    assert below_nine.update_time_bits == 14
    assert (nine.update_time_bits, nine.timing_bits) == (15, 16)
