"""Node IDs: the 16-bit address of a node, as bus number and physical ID.

IEEE 1394-1995 §6.2.4.2: a node ID is a 10-bit bus ID over a 6-bit physical
ID. Bus ID 0x3FF names the local bus; physical ID 63 addresses every node of a
bus (broadcast), so 0xFFFF is a broadcast on the local bus. Every module that
builds or reads a node ID uses these names instead of its own constants.
"""

from __future__ import annotations

#: Bus ID of "this bus", whatever its number.
LOCAL_BUS = 0x3FF
#: The physical ID every node answers to (broadcast); never a node's own ID.
BROADCAST_PHY = 63
#: The physical-ID bits of a node ID, as a mask (for arrays of node IDs).
PHY_ID_MASK = BROADCAST_PHY
#: How many nodes one bus can hold (physical IDs 0-62).
MAX_NODES = 63
#: The local bus's broadcast address.
BROADCAST_ID = LOCAL_BUS << 6 | BROADCAST_PHY
#: Node ID of physical ID 0 on the local bus (0xFFC0).
LOCAL_BASE = LOCAL_BUS << 6


def node_id(phy: int, bus: int = LOCAL_BUS) -> int:
    """The node ID of physical ID ``phy`` on bus ``bus`` (the local bus by default)."""
    if not 0 <= phy <= BROADCAST_PHY:
        raise ValueError(f"physical ID {phy} is outside 0-63")
    if not 0 <= bus <= LOCAL_BUS:
        raise ValueError(f"bus ID {bus} is outside 0-1023")
    return bus << 6 | phy


def phy_of(node: int) -> int:
    """The physical ID (low 6 bits) of a 16-bit node ID."""
    return node & BROADCAST_PHY


def bus_of(node: int) -> int:
    """The bus ID (high 10 bits) of a 16-bit node ID."""
    return node >> 6 & LOCAL_BUS


def is_broadcast(node: int) -> bool:
    """Whether ``node`` addresses every node of its bus."""
    return node & BROADCAST_PHY == BROADCAST_PHY


def resolve(node: int) -> int:
    """A physical ID 0-63 as a local-bus node ID; a full 16-bit node ID as it is."""
    if 0 <= node <= BROADCAST_PHY:
        return LOCAL_BASE | node
    if 0 <= node <= 0xFFFF:
        return node
    raise ValueError(f"node {node} is neither a physical ID (0-63) nor a 16-bit node ID")
