"""Register maps: the decoding rules, and every emulator checked against its own map."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.boards.registry import BOARDS, make_board
from fw1394.boards.regmap import (
    ETHERNET,
    FIREWIRE,
    OFFSET_MASK,
    Decoding,
    Group,
    IgnoredBits,
    Placed,
    Register,
    RegisterMap,
    Window,
)
from fw1394.engine.space import AddressSpace

MAPPED = sorted(kind for kind, entry in BOARDS.items() if entry.registers is not None)
offsets = st.integers(0, OFFSET_MASK)


def fresh(kind: str) -> AddressSpace:
    return make_board(kind, board_id=0)


def placed(kind: str) -> list[Placed]:
    registers = BOARDS[kind].registers
    assert registers is not None
    return list(registers.placed())


# -- the decoding rules ------------------------------------------------------------------


@given(offsets, st.integers(1, (1 << 32) - 1))
def test_an_alias_decodes_like_the_address_it_aliases(offset: int, high: int) -> None:
    decoding = Decoding(kept=0xFFFF)
    address = decoding.address(offset)
    alias = decoding.aliases(address, high)
    assert alias != address
    assert decoding.address(alias) == address == offset & 0xFFFF


def test_bits_ignored_in_one_space_alias_only_there() -> None:
    # Bits 11..8 ignored in space 0 (bits 15..12 clear), decoded elsewhere.
    decoding = Decoding(kept=0xFFFF, ignored=(IgnoredBits(0x0F00, 0xF000, 0x0000),))
    assert decoding.address(0x0304) == 0x0004
    assert decoding.address(0x1304) == 0x1304
    assert decoding.address(0xABCD_0F10) == 0x0010


def test_a_window_is_decoded_whole_before_the_kept_bits() -> None:
    decoding = Decoding(kept=0xFFFF, windows=(Window(0xFFFF_F000_0000, 0x1000),))
    assert decoding.address(0xFFFF_F000_0400) == 0xFFFF_F000_0400
    assert decoding.address(0xFFFF_F000_1400) == 0x1400
    with pytest.raises(ValueError, match="48-bit"):
        decoding.address(1 << 48)


def test_lookup_by_name_and_copy() -> None:
    group = Group("channel", (Register("A", 0), Register("B", 1)), copies=range(1, 3), stride=16)
    registers = RegisterMap("toy", (Group("top", (Register("S", 0),)), group))
    assert registers.offset("B", 2) == 0x21
    assert registers.offset("B") == 0x11  # the first copy
    assert registers.offset("S") == 0
    with pytest.raises(KeyError):
        registers.offset("B", 3)
    with pytest.raises(KeyError, match="no register"):
        registers.offset("C")
    hit = registers.at(0x20)
    assert hit is not None and (hit.register.name, hit.copy) == ("A", 2)
    assert registers.at(0x22) is None
    assert len(registers.with_copies("channel", range(1, 2)).group("channel").copies) == 1


def test_the_qla1_paths_differ_only_in_the_csr_window() -> None:
    registers = BOARDS["qla1"].registers
    assert registers is not None
    node_ids = registers.offset("NODE_IDS")
    assert registers.decode(node_ids, FIREWIRE) == node_ids
    assert registers.decode(node_ids, ETHERNET) == node_ids & 0xFFFF
    assert registers.decode(0xFFFF_FFFF_0004, FIREWIRE) == 4
    assert registers.decode(0xFFFF_FFFF_0004, ETHERNET) == 4


# -- each emulator against its map -------------------------------------------------------


@pytest.mark.parametrize("kind", MAPPED)
def test_power_up_values_are_the_maps(kind: str) -> None:
    board = fresh(kind)
    checked = 0
    for spot in placed(kind):
        if spot.register.reset is not None:
            value = board.read_quadlet(spot.address)
            assert value == spot.register.reset, (spot.register.name, spot.copy, hex(value))
            checked += 1
    assert checked


@pytest.mark.parametrize("kind", MAPPED)
def test_registers_answer_at_every_alias_the_map_allows(kind: str) -> None:
    registers = BOARDS[kind].registers
    assert registers is not None
    decoding = registers.decodings[FIREWIRE]
    board = fresh(kind)
    for spot in placed(kind):
        in_window = any(spot.address in window for window in decoding.windows)
        if spot.register.reset is None or in_window:
            continue
        for high in (1, 0xABCD, 0xFFFF_FFFF):
            alias = decoding.aliases(spot.address, high)
            if alias == spot.address:
                continue  # every offset bit decoded: nothing aliases
            assert board.read_quadlet(alias) == spot.register.reset, (spot.register.name, alias)


@pytest.mark.parametrize("kind", MAPPED)
def test_read_only_registers_ignore_writes(kind: str) -> None:
    board = fresh(kind)
    for spot in placed(kind):
        if spot.register.access != "ro" or spot.register.reset is None:
            continue
        board.write_quadlet(spot.address, 0x5A5A_5A5A)
        assert board.read_quadlet(spot.address) == spot.register.reset, spot.register.name


@pytest.mark.parametrize("kind", MAPPED)
def test_the_maps_registers_are_the_only_thing_decoded(kind: str) -> None:
    # Addresses inside a register group that the map leaves empty read 0.
    registers = BOARDS[kind].registers
    assert registers is not None
    board = fresh(kind)
    for group in registers.groups:
        if not group.stride:
            continue
        for copy in group.copies:
            start = group.base + copy * group.stride
            for address in range(start, start + group.stride):
                if registers.at(address) is None:
                    assert board.read_quadlet(address) == 0, (group.name, hex(address))


def test_a_register_map_knows_the_probe_it_names() -> None:
    for kind in MAPPED:
        registers = BOARDS[kind].registers
        assert registers is not None
        board = fresh(kind)
        board.read_quadlet(registers.offset(registers.probe))


def test_the_z_theta_map_has_the_boards_four_channels() -> None:
    registers = BOARDS["snake2010-ztheta"].registers
    assert registers is not None
    board = fresh("snake2010-ztheta")
    assert len(registers.group("channel").copies) == len(board.channels) == 4  # type: ignore[attr-defined]
