"""What the bench measures: a node on a virtual bus, or a board behind the JHU Eth1394 tunnel.

Every experiment uses the same four calls at fixed offsets, chosen to
change nothing on the thesis and QLA boards:

* quadlet reads and writes at offset 0, the status register: a read has no
  side effect, and a write of 0 has an empty enable mask (bits 15-8), so no
  amplifier changes;
* block reads and writes at offset 0, the real-time block: a read of any
  length is the block cut or padded, a write of zeros has every valid bit
  clear (snake2010) or is a chain of empty block headers (QLA firmware 8
  and later), so no DAC changes. Writes still feed the watchdog.

A memory node (``bus up`` without ``--board``) stores the zeros.
Do not point the bench at a real board whose amplifiers are powered.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Protocol

from fw1394.experiments.timing import TargetError
from fw1394.host.bus_port import BusPort
from fw1394.jhu.client import EthUdpClient
from fw1394.transport.bus_host import BusError, TransactionError
from fw1394.transport.supervision.runtime import bus_dir, read_nodes

QUADLET_OFFSET = 0
BLOCK_OFFSET = 0


class Target(Protocol):
    """One node the bench talks to; failures raise :class:`TargetError`."""

    def read_quadlet(self) -> None: ...
    def write_quadlet(self) -> None: ...
    def read_block(self, quadlets: int) -> None: ...
    def write_block(self, quadlets: int) -> None: ...
    def peer_pids(self) -> list[int]: ...
    def describe(self) -> dict[str, object]: ...


_ZEROS = bytes(4 * 512)


@dataclass
class BusTarget:
    """Node ``node`` (a physical ID) of the bus ``port`` is on."""

    port: BusPort
    node: int
    kind: str = "bus"
    board: str = "unknown"
    pids: list[int] = field(default_factory=list)

    def read_quadlet(self) -> None:
        try:
            self.port.read_quadlet(self.node, QUADLET_OFFSET)
        except (TransactionError, BusError) as error:
            raise TargetError(str(error)) from None

    def write_quadlet(self) -> None:
        try:
            self.port.write_quadlet(self.node, QUADLET_OFFSET, 0)
        except (TransactionError, BusError) as error:
            raise TargetError(str(error)) from None

    def read_block(self, quadlets: int) -> None:
        try:
            self.port.read_block(self.node, BLOCK_OFFSET, 4 * quadlets)
        except (TransactionError, BusError) as error:
            raise TargetError(str(error)) from None

    def write_block(self, quadlets: int) -> None:
        try:
            self.port.write_block(self.node, BLOCK_OFFSET, _ZEROS[: 4 * quadlets])
        except (TransactionError, BusError) as error:
            raise TargetError(str(error)) from None

    def peer_pids(self) -> list[int]:
        return list(self.pids)

    def describe(self) -> dict[str, object]:
        return {
            "kind": self.kind,
            "bus": self.port.config.name,
            "node": self.node,
            "board": self.board,
            "writes_acknowledged": True,
        }


def bus_node_board(bus: str, pid: int) -> tuple[str, list[int]]:
    """Board kind and pid of the node process ``pid`` of a bus started on this host."""
    for record in read_nodes(bus_dir(bus)):
        if record.pid == pid:
            return record.board, [pid]
    return "unknown", [pid] if pid else []


@dataclass
class Eth1394Target:
    """Board ``node`` behind an Eth1394 server, reached the way the JHU host library does.

    Eth1394 answers reads only: the host library's writes are fire-and-forget
    datagrams, so a write's time is the time to hand it to the kernel.
    """

    client: EthUdpClient
    node: int
    board_id: int
    firmware: int
    bridge: bool
    server_pids: list[int] = field(default_factory=list)

    def read_quadlet(self) -> None:
        logged = len(self.client.state.log)
        if self.client.read_quadlet_node(self.node, QUADLET_OFFSET) is None:
            raise TargetError(self._problem("quadlet read", logged))

    def write_quadlet(self) -> None:
        logged = len(self.client.state.log)
        if not self.client.write_quadlet_node(self.node, QUADLET_OFFSET, 0):
            raise TargetError(self._problem("quadlet write", logged))

    def read_block(self, quadlets: int) -> None:
        logged = len(self.client.state.log)
        if self.client.read_block_node(self.node, BLOCK_OFFSET, 4 * quadlets) is None:
            raise TargetError(self._problem(f"{quadlets}-quadlet block read", logged))

    def write_block(self, quadlets: int) -> None:
        logged = len(self.client.state.log)
        if not self.client.write_block_node(self.node, BLOCK_OFFSET, _ZEROS[: 4 * quadlets]):
            raise TargetError(self._problem(f"{quadlets}-quadlet block write", logged))

    def peer_pids(self) -> list[int]:
        return list(self.server_pids)

    def describe(self) -> dict[str, object]:
        return {
            "kind": "eth1394",
            "server": f"{self.client.server}:{self.client.port}",
            "node": self.node,
            "board_id": self.board_id,
            "board": "qla1",
            "firmware": self.firmware,
            "mode": "bridge" if self.bridge else "ethernet-only",
            "writes_acknowledged": False,
        }

    def _problem(self, what: str, logged: int) -> str:
        # The host logs why (generation, size, label); a failure it did not log is a timeout.
        said = self.client.state.log[logged:]
        return f"{what}: {said[-1] if said else 'no answer within 20 ms'}"
