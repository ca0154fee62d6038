"""The contracts a node is held to, and the words findings are described in.

A contract is one of the engine's responder policies: what the thesis FPGA
promises (drop damaged packets, ignore other nodes and unsupported tcodes),
what the JHU firmware does, or what IEEE 1394 asks of an ordinary node. The
reference model answers every case as the contract says, so the contract is
also what decides which writes count as accepted.
"""

from __future__ import annotations

from fw1394.boards.qla1.paths import ETHERNET_PATH, Path
from fw1394.engine import IEEE1394_NODE, JHU_FIRMWARE, THESIS_FPGA, ResponderPolicy
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
    Request,
    name_of,
)
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS, bus_of, phy_of

CONTRACTS: dict[str, ResponderPolicy] = {
    "thesis": THESIS_FPGA,
    "jhu": JHU_FIRMWARE,
    "ieee1394": IEEE1394_NODE,
}
#: Contracts whose node answers differently over Eth1394: the JHU firmware's
#: Ethernet path (no CRC checked, 16 offset bits, no answer to writes), the same
#: description the emulated boards serve through.
ETH1394_PATHS: dict[str, Path] = {"jhu": ETHERNET_PATH}
_FAMILIES: dict[type[AsyncPacket], str] = {
    QuadletReadRequest: "read",
    BlockReadRequest: "read",
    QuadletWriteRequest: "write",
    BlockWriteRequest: "write",
    LockRequest: "lock",
}


def contract_path(contract: str, eth1394: bool) -> Path | None:
    """The path a contract's node is reached over, where the contract says how it differs.

    None: the contract's policy alone says how the node answers (FireWire, and
    contracts that know no Ethernet path).
    """
    return ETH1394_PATHS.get(contract) if eth1394 else None


def family(packet: AsyncPacket | None) -> str:
    """``read``, ``write``, ``lock``, ``other`` (responses, streams) or ``undecodable``."""
    if packet is None:
        return "undecodable"
    return _FAMILIES.get(type(packet), "other")


def ack_name(ack: int | None) -> str:
    return "silence" if ack is None else name_of(AckCode, ack)


def silence_reason(
    packet: AsyncPacket | None, damaged: bool, node_id: int, policy: ResponderPolicy
) -> str:
    """Why the contract wants no answer to this packet (the first reason that applies).

    The order is the responder's screens (``docs/engine.md``); the words are the
    ones findings use.
    """
    if packet is None:
        return "undecodable"
    if not isinstance(packet, Request) or type(packet) not in _FAMILIES:
        return "not-a-request"
    node = phy_of(packet.destination_id)
    bus = bus_of(packet.destination_id)
    if not policy.ignore_bus_id and bus not in (LOCAL_BUS, bus_of(node_id)):
        return "other-bus"
    if node not in (BROADCAST_PHY, phy_of(node_id)):
        return "other-node"
    if isinstance(packet, LockRequest) and not policy.locks:
        return "unsupported-tcode"
    if damaged:
        return _damage(packet)
    if node == BROADCAST_PHY:
        return "broadcast"
    return "contract"


def _damage(packet: AsyncPacket) -> str:
    fields = {problem.field for problem in packet.problems}
    if "header_crc" in fields:
        return "bad-header-crc"
    if fields & {"data", "length"} or ("data_crc" in fields and packet.data_crc_ok is None):
        return "bad-length"
    return "bad-data-crc"
