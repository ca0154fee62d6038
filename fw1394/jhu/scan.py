"""The host's start-up: InitNodes, ScanNodes, SetDefaultProtocol, OptimizeFirewireGapCount.

Step by step as jhu-eth1394.md §4.9 lists them, with the same flags, waits
and failure rules; the result says what the library would have found.
"""

from __future__ import annotations

import enum
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from fw1394.boards.qla1.regs import BoardRegister, ip_to_register
from fw1394.jhu.client import MAX_BOARDS, EthUdpClient
from fw1394.packets.eth1394 import BROADCAST_NODE, HostNodeFlag

#: Hardware versions the library accepts: 'QLA1', 'dRA1', 'DQLA', 'BCFG', 'TEST'.
SUPPORTED_HARDWARE = frozenset({0x514C4131, 0x64524131, 0x44514C41, 0x42434647, 0x54455354})
BOARD_ID_MASK = 0x0F000000
HUB_FLAGS = HostNodeFlag.NO_FORWARD | HostNodeFlag.ETH_BROADCAST
IP_WRITE_PAUSE = 0.2
PHY_REQUEST_PAUSE = 0.01
#: Gap count for 1..24 nodes on one long chain; entry 0 is the power-up default.
DEFAULT_GAP_COUNT = 63  # not a node ID: the power-up and largest gap count
GAP_COUNTS = (DEFAULT_GAP_COUNT, 5, 7, 8, 10, 13, 16, 18, 21, 24, 26, 29, 32, 35, 37, 40, 43,
              46, 48, 51, 54, 57, 59, 62, DEFAULT_GAP_COUNT)  # fmt: skip
#: PHY register 1's gap-count field (IEEE 1394a PHY register map).
GAP_COUNT_MASK = 0x3F  # not a node ID
PHY_READ = 1  # FW_PHY_REQ value: read PHY register 1
PHY_WRITE_GAP = 0x1100  # FW_PHY_REQ: write (bit 12) PHY register 1 (bits 11..8)


class Protocol(enum.Enum):
    """How the real-time loop reaches the boards (BasePort protocols)."""

    SEQ_RW = "sequential"  # one read and one write per board
    SEQ_R_BC_W = "broadcast-write"  # reads per board, one broadcast write
    BC_QRW = "broadcast-read-write"  # broadcast query + hub read, broadcast write


@dataclass(frozen=True)
class ScannedBoard:
    node: int
    board_id: int
    hardware: int
    firmware: int
    fpga_version: int
    git_description: int


@dataclass
class ScanResult:
    """What the host's start-up scan found: the boards, the hub, the protocol to use."""

    boards: list[ScannedBoard] = field(default_factory=list)
    hub_board: int = 0
    bridge: bool = False
    protocol: Protocol = Protocol.SEQ_RW
    gap_count_written: int | None = None

    @property
    def ok(self) -> bool:
        return bool(self.boards)

    def node_of(self, board_id: int) -> int:
        for board in self.boards:
            if board.board_id == board_id:
                return board.node
        raise KeyError(f"board {board_id} was not found by the scan")


def fpga_major(eth_status: int) -> int:
    """FPGA generation from ETH_STATUS: 0 = V1, bit 31 = V2, bits 31..30 = 01 = V3, else 0."""
    if eth_status == 0:
        return 1
    if eth_status & 0x80000000:
        return 2
    return 3 if eth_status >> 30 == 1 else 0


def init_nodes(client: EthUdpClient) -> int:
    """EthUdpPort::InitNodes: the hub's identity and the choice of mode; nodes to scan."""
    state = client.state
    ip_value = ip_to_register(client.server)
    if not client.write_quadlet_node(
        BROADCAST_NODE, BoardRegister.IP_ADDRESS, ip_value, HostNodeFlag.ETH_BROADCAST
    ):
        client.say("InitNodes: failed to write IP address")
        return 0
    time.sleep(IP_WRITE_PAUSE)
    hardware = client.read_quadlet_node(BROADCAST_NODE, BoardRegister.HARDWARE_VERSION, HUB_FLAGS)
    if hardware is None:
        client.say("InitNodes: failed to read hardware version for hub/bridge board")
        return 0
    if hardware not in SUPPORTED_HARDWARE:
        client.say(f"InitNodes: hub board is not a supported board, data = {hardware:x}")
        return 0
    state.generation = state.new_generation
    client.say(f"InitNodes: Firewire bus generation = {state.generation}")
    if not client.write_quadlet_node(
        BROADCAST_NODE, BoardRegister.FW_PHY_REQ, 0, HostNodeFlag.ETH_BROADCAST
    ):
        client.say("InitNodes: failed to broadcast PHY command")
        return 0
    time.sleep(PHY_REQUEST_PAUSE)
    status = client.read_quadlet_node(BROADCAST_NODE, BoardRegister.STATUS, HUB_FLAGS)
    if status is None:
        client.say("InitNodes: failed to read board id for hub/bridge board")
        return 0
    state.hub_board = (status & BOARD_ID_MASK) >> 24
    client.say(f"InitNodes: found hub board: {state.hub_board}")
    firmware = client.read_quadlet_node(BROADCAST_NODE, BoardRegister.FIRMWARE_VERSION, HUB_FLAGS)
    if firmware is None:
        client.say("InitNodes: unable to read firmware version from hub/bridge board")
        return 0
    state.firmware[state.hub_board] = firmware
    eth_status = client.read_quadlet_node(BROADCAST_NODE, BoardRegister.ETH_STATUS, HUB_FLAGS)
    if eth_status is None:
        client.say("InitNodes: failed to read Ethernet status from hub/bridge board")
        return 0
    fpga = fpga_major(eth_status)
    if not state.use_bridge and (fpga != 3 or firmware < 9):
        reason = f"is FPGA V{fpga}" if fpga != 3 else f"has Firmware Rev {firmware}"
        client.say(f"InitNodes: hub board {reason}, using Ethernet/Firewire bridge")
        state.use_bridge = True
    elif state.use_bridge:
        client.say("InitNodes: using Ethernet/Firewire bridge")
    else:
        client.say("InitNodes: using Ethernet network")
    return MAX_BOARDS


def scan_nodes(client: EthUdpClient, nodes: int) -> list[ScannedBoard]:
    """BasePort::ScanNodes: the five reads per node; absent nodes time out."""
    found: list[ScannedBoard] = []
    say = client.say
    say(f"BasePort::ScanNodes: building node map for {nodes} nodes:")
    for node in range(nodes):
        hardware = client.read_quadlet_node(node, BoardRegister.HARDWARE_VERSION)
        if hardware is None:
            continue  # the UDP port says nothing here (only FireWire does)
        if hardware not in SUPPORTED_HARDWARE:
            say(f"BasePort::ScanNodes: node {node} is not a supported board (data = {hardware:x})")
            continue
        firmware = client.read_quadlet_node(node, BoardRegister.FIRMWARE_VERSION)
        if firmware is None:
            say(f"BasePort::ScanNodes: unable to read firmware version from node {node}")
            continue
        fpga = 1
        if firmware >= 5:
            eth_status = client.read_quadlet_node(node, BoardRegister.ETH_STATUS)
            if eth_status is None:
                say(
                    "BasePort::ScanNodes: unable to read FPGA version (ETH_STATUS) "
                    f"from node {node}"
                )
                continue
            fpga = fpga_major(eth_status)
        status = client.read_quadlet_node(node, BoardRegister.STATUS)
        if status is None:
            say(f"BasePort::ScanNodes: unable to read status from node {node}")
            continue
        board_id = (status & BOARD_ID_MASK) >> 24
        client.state.firmware[board_id] = firmware
        git = client.read_quadlet_node(node, BoardRegister.GIT_DESCRIPTION)
        if git is None:
            say(f"BasePort::ScanNodes: unable to read git desc from node {node}")
        name = hardware.to_bytes(4, "big").decode("ascii", "replace")
        say(
            f"  Node {node}, BoardId = {board_id}, FPGA_V{fpga or '?'}, Hardware = {name}, "
            f"Firmware Version = {firmware}{git_suffix(git or 0)}"
        )
        found.append(ScannedBoard(node, board_id, hardware, firmware, fpga, git or 0))
    say(f"BasePort::ScanNodes: found {len(found)} boards")
    return found


def git_suffix(git_description: int) -> str:
    """What the scan line appends for GIT_DESC: "+", "-" or "?" and the SHA (none for 0)."""
    if not git_description:
        return ""
    dirty, commits, flag = bool(git_description & 8), bool(git_description & 4), git_description & 3
    if flag == 0:
        if not (dirty or commits):
            return ""
        mark = "+"
    else:
        mark = "-" if flag == 1 else "?"
    return f"{mark} (git-{git_description >> 4:07x}{'*' if dirty else ''})"


def default_protocol(
    boards: list[ScannedBoard], say: Callable[[str], None] | None = None
) -> Protocol:
    """BasePort::SetDefaultProtocol: broadcast write when every board can and the mix is valid."""
    revisions = {board.firmware for board in boards}
    if not revisions or min(revisions) < 4:
        return Protocol.SEQ_RW
    shorter_wait = revisions in ({6}, {7}) or revisions <= {8, 9}
    valid_mix = revisions <= {4, 5, 6} or revisions == {7} or revisions <= {8, 9}
    prefix = "BasePort::SetDefaultProtocol: all nodes broadcast capable"
    if not valid_mix:
        message = f"{prefix}, but disabled due to mix of firmware"
    elif shorter_wait:
        message = f"{prefix} and support shorter wait"
    elif revisions <= {4, 5}:
        message = f"{prefix} and do not support shorter wait"
    else:
        message = f"{prefix} and some support shorter wait"
    if say is not None:
        say(message)
    return Protocol.SEQ_R_BC_W if valid_mix else Protocol.SEQ_RW


def optimize_gap_count(client: EthUdpClient, nodes: int) -> int | None:
    """EthBasePort::OptimizeFirewireGapCount; the gap count written, or None."""
    if not client.write_quadlet_node(BROADCAST_NODE, BoardRegister.FW_PHY_REQ, PHY_READ):
        client.say("OptimizeFirewireGapCount: failed to broadcast PHY command")
        return None
    gaps = []
    for node in range(nodes):
        response = client.read_quadlet_node(node, BoardRegister.FW_PHY_RESP)
        if response is None:
            return None
        gaps.append(response & GAP_COUNT_MASK)
    low, high = min(gaps, default=DEFAULT_GAP_COUNT), max(gaps, default=0)
    if low == high:
        client.say(f"OptimizeFirewireGapCount: current gap count is {low}")
    else:
        client.say(f"OptimizeFirewireGapCount: inconsistent gap counts ({low}-{high})")
    if low == high and low != DEFAULT_GAP_COUNT:
        return None
    gap = GAP_COUNTS[nodes] if nodes < len(GAP_COUNTS) else DEFAULT_GAP_COUNT
    client.say(f"OptimizeFirewireGapCount: updating gap count to {gap}")
    if not client.write_quadlet_node(BROADCAST_NODE, BoardRegister.FW_PHY_REQ, PHY_WRITE_GAP | gap):
        return None
    return gap


def start(client: EthUdpClient) -> ScanResult:
    """The whole port start-up (EthUdpPort::Init); logs "Initialization done/failed"."""
    result = ScanResult()
    nodes = init_nodes(client)
    result.boards = scan_nodes(client, nodes)
    result.hub_board = client.state.hub_board
    result.bridge = client.state.use_bridge
    if result.ok:
        result.protocol = default_protocol(result.boards, client.say)
        if result.bridge:
            result.gap_count_written = optimize_gap_count(client, len(result.boards))
    client.say("Initialization done" if result.ok else "Initialization failed")
    return result
