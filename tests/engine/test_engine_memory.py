"""MemorySpace, the plain memory a virtual node serves."""

from __future__ import annotations

from collections.abc import Callable

import pytest

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine.space import AddressError, AddressSpace, DataError


def test_is_an_address_space() -> None:
    assert isinstance(MemorySpace(), AddressSpace)


def test_byte_addressing() -> None:
    space = MemorySpace(16, base=0x1000, contents=bytes(range(8)))
    assert space.read_quadlet(0x1004) == 0x04050607
    assert space.read_block(0x1002, 4) == bytes([2, 3, 4, 5])
    space.write_block(0x1001, b"\xaa\xbb")
    space.write_quadlet(0x100C, 0x01020304)
    assert space.contents() == bytes([0, 0xAA, 0xBB, 3, 4, 5, 6, 7]) + bytes(4) + b"\1\2\3\4"


@pytest.mark.parametrize(
    "access",
    [
        lambda s: s.read_quadlet(0x1002),  # misaligned
        lambda s: s.read_quadlet(0x0FFC),  # below the base
        lambda s: s.read_quadlet(0x1010),  # past the end
        lambda s: s.read_block(0x100E, 4),  # runs off the end
        lambda s: s.write_quadlet(1 << 40, 0),
    ],
)
def test_address_errors(access: Callable[[MemorySpace], object]) -> None:
    space = MemorySpace(16, base=0x1000)
    with pytest.raises(AddressError):
        access(space)


def test_quadlet_index_addressing() -> None:
    space = MemorySpace(16, quadlet_index=True, contents=bytes(range(16)))
    assert space.read_quadlet(1) == 0x04050607
    assert space.read_block(2, 8) == bytes(range(8, 16))
    space.write_block(0, b"\xff" * 8)
    assert space.read_quadlet(1) == 0xFFFFFFFF
    with pytest.raises(DataError):
        space.read_block(0, 6)
    with pytest.raises(AddressError):
        space.read_quadlet(4)


def test_mask_aliases_high_offset_bits() -> None:
    space = MemorySpace(64, quadlet_index=True, mask=0xFFFF)
    space.write_quadlet(0xFFFF_0000_0003, 7)
    assert space.read_quadlet(3) == 7


def test_time_and_board_factory_keywords() -> None:
    space = MemorySpace(board_id=3)
    space.set_time(1234)
    assert (space.ticks, space.board_id, space.size) == (1234, 3, 4096)
    with pytest.raises(ValueError):
        MemorySpace(defects=frozenset({"stuck_bit"}))
    with pytest.raises(ValueError):
        MemorySpace(6)
    with pytest.raises(ValueError):
        MemorySpace(4, contents=b"12345")
