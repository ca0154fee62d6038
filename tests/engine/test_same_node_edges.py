"""Node IDs name the same node when bus and physical ID agree, bus 0x3FF meaning the
local bus (IEEE 1394-1995: a node ID is a 10-bit bus ID and a 6-bit physical ID)."""

from __future__ import annotations

import pytest

from fw1394.engine.transaction import same_node


@pytest.mark.parametrize(
    ("a", "b", "same"),
    [
        (0xFFC2, 0xFFC2, True),
        (0xFFC1, 0xFFC2, False),  # local bus, phys 1 and 2
        (0xFFC2, 0xFFC1, False),
        (0x0042, 0xFFC2, True),  # bus 1, phy 2 and "this bus", phy 2
        (0xFFC2, 0x0042, True),
        (0x0042, 0x0082, False),  # bus 1 and bus 2, both phy 2
        (0x0041, 0x0042, False),
    ],
)
def test_same_node_compares_bus_and_phy(a: int, b: int, same: bool) -> None:
    assert same_node(a, b) is same
