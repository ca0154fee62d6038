"""The fuzzer's offsets are the registered boards' register maps, not a list of their own."""

from __future__ import annotations

import pytest

from fw1394.boards.registry import BOARDS, make_board
from fw1394.boards.regmap import FIREWIRE
from fw1394.fuzz.offsets import aliased, offset_model

MAPPED = sorted(kind for kind, entry in BOARDS.items() if entry.registers is not None)


@pytest.mark.parametrize("kind", MAPPED)
def test_every_register_of_the_map_is_a_target_offset(kind: str) -> None:
    registers = BOARDS[kind].registers
    assert registers is not None
    model = offset_model(kind)
    offsets = set(model.registers)
    for spot in registers.placed():
        assert spot.address in offsets, (spot.register.name, spot.copy)
    assert set(registers.spots) <= offsets
    assert model.quadlet_index == registers.quadlet_index
    assert model.probe == registers.offset(registers.probe)


@pytest.mark.parametrize("kind", MAPPED)
def test_the_sweep_rereads_exactly_the_writable_registers(kind: str) -> None:
    registers = BOARDS[kind].registers
    assert registers is not None
    model = offset_model(kind)
    for offset in model.sweep:
        spot = registers.at(offset)
        assert spot is not None and spot.register.access == "rw", hex(offset)
    single = {p.address for p in registers.placed() if p.register.access == "rw"}
    assert single <= set(model.sweep)


@pytest.mark.parametrize("kind", MAPPED)
def test_the_probe_answers_the_same_through_an_alias(kind: str) -> None:
    registers = BOARDS[kind].registers
    assert registers is not None
    board = make_board(kind, board_id=0)
    probe = offset_model(kind).probe
    value = board.read_quadlet(probe)
    decoding = registers.decodings[FIREWIRE]
    alias = decoding.aliases(probe, 0x1234)
    if alias != probe:
        assert board.read_quadlet(alias) == value
        assert decoding.address(aliased(probe, 0x1234)) == probe


def test_a_kind_without_a_map_gets_the_generic_offsets() -> None:
    assert offset_model(None) == offset_model("no-such-kind")
    assert not offset_model(None).quadlet_index


def test_fewer_channels_mean_fewer_offsets() -> None:
    seven, four = offset_model("snake2010"), offset_model("snake2010-ztheta")
    assert set(four.registers) < set(seven.registers)
    assert 0x51 in seven.registers and 0x51 not in four.registers
