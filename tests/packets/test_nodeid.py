"""The node-ID vocabulary against IEEE 1394's own numbers."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.packets import nodeid


def test_the_standard_numbers() -> None:
    assert nodeid.BROADCAST_ID == 0xFFFF
    assert nodeid.LOCAL_BASE == 0xFFC0
    assert nodeid.node_id(0) == 0xFFC0
    assert nodeid.node_id(2, bus=0) == 0x0002
    assert nodeid.resolve(5) == 0xFFC5
    assert nodeid.resolve(0x1234) == 0x1234


@given(st.integers(0, 63), st.integers(0, 0x3FF))
def test_node_id_round_trip(phy: int, bus: int) -> None:
    node = nodeid.node_id(phy, bus)
    assert (nodeid.phy_of(node), nodeid.bus_of(node)) == (phy, bus)
    assert nodeid.is_broadcast(node) == (phy == 63)


@pytest.mark.parametrize("bad", [-1, 0x10000])
def test_resolve_refuses_what_is_no_node(bad: int) -> None:
    with pytest.raises(ValueError):
        nodeid.resolve(bad)
