"""The self-ID packets of a virtual bus: a daisy chain with the root at the end.

Physical IDs are handed out in self-ID order, which 1394's tree identify makes
a post-order walk of the tree. Modelling the cable as a chain 0 - 1 - ... - N-1
with N-1 as root gives exactly IDs 0..N-1 along the chain: every node's port 0
leads to its parent (the next higher ID) and port 1 to its child (the next
lower ID); port 2 is present but unplugged.
"""

from __future__ import annotations

from fw1394.packets import PortStatus, SelfIdPacket, Speed, encode
from fw1394.packets.accessors import PHY_IDENTIFIER

#: The identifier of self-ID packets (PHY packet bits 31-30).
SELF_ID_IDENTIFIER = SelfIdPacket.SELECTOR["identifier"]
#: The gap count every PHY uses after a reset until a PHY configuration packet says otherwise.
DEFAULT_GAP_COUNT = 0x3F  # not a node ID: the largest gap count


def self_id_packet(
    phy_id: int,
    count: int,
    *,
    contender: bool,
    initiated_reset: bool,
    speed: int = Speed.S400,
) -> SelfIdPacket:
    """Self-ID packet #0 of node ``phy_id`` on a chain of ``count`` nodes."""
    is_root = phy_id == count - 1
    return SelfIdPacket(
        phy_id=phy_id,
        link_active=True,
        gap_count=DEFAULT_GAP_COUNT,
        scode=speed,
        contender=contender,
        power_class=0,
        port0=PortStatus.not_connected if is_root else PortStatus.parent,
        port1=PortStatus.child if phy_id > 0 else PortStatus.not_connected,
        port2=PortStatus.not_connected,
        initiated_reset=initiated_reset,
        more_packets=False,
    )


def self_id_bytes(
    phy_id: int, count: int, *, contender: bool, initiated_reset: bool, speed: int = Speed.S400
) -> bytes:
    packet = self_id_packet(
        phy_id, count, contender=contender, initiated_reset=initiated_reset, speed=speed
    )
    return encode(packet)


def is_self_id(raw: bytes) -> bool:
    """A PHY packet whose identifier is 2 (self-ID, any sequence number)."""
    return len(raw) >= 4 and PHY_IDENTIFIER.of_bytes(raw) == SELF_ID_IDENTIFIER
