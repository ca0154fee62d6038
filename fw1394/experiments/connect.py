"""``--target`` specifications, and opening the target they name.

* ``virtual`` (the default): a fresh bus of the bench's own with one board
  (``snake2010`` unless told otherwise), torn down at the end;
* ``bus:NAME/NODE``: physical ID NODE of a bus that is already up (``fw1394
  bus up --name NAME``); the bench joins it as a host, as ``fw1394 read`` does;
* ``udp:HOST[:PORT]`` with ``--eth1394``: a QLA board behind a JHU Eth1394
  server (``fw1394 jhu serve``, default port 1394), loopback only.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from fw1394.errors import BusUnreachable
from fw1394.experiments.bench_targets import BusTarget, Eth1394Target, Target, bus_node_board
from fw1394.experiments.private_bus import SETTLE_S, TIMING, TRANSACTION_TIMEOUT_S, PrivateBus
from fw1394.host.bus_port import BusPort
from fw1394.jhu.client import EthUdpClient
from fw1394.jhu.scan import start
from fw1394.transport.bus_host import BusError
from fw1394.transport.eth1394_addresses import (
    AddressRefusedError,
    Endpoint,
    parse_endpoint,
    require_loopback,
)
from fw1394.transport.sansio.config import BusConfig, parse_bus_node

VIRTUAL = "virtual"


class TargetUnavailable(BusUnreachable):
    """The target cannot be reached or is not what the specification says."""


@dataclass(frozen=True)
class TargetSpec:
    kind: str  # "virtual", "bus" or "udp"
    bus: str = ""
    node: int = 0
    endpoint: Endpoint | None = None


def parse_target(text: str | None, *, eth1394: bool = False) -> TargetSpec:
    """The target ``text`` names; ValueError with a message for the user otherwise."""
    if text in (None, "", VIRTUAL):
        if eth1394:
            raise ValueError("--eth1394 goes with --target udp:HOST[:PORT]")
        return TargetSpec(VIRTUAL)
    assert text is not None
    scheme, colon, rest = text.partition(":")
    if scheme == "bus" and colon:
        if eth1394:
            raise ValueError("--eth1394 goes with --target udp:HOST[:PORT], not a bus target")
        name, node = parse_bus_node(rest)
        return TargetSpec("bus", bus=name, node=node)
    if scheme == "udp" and colon:
        if not eth1394:
            raise ValueError(
                f"{text!r}: say which tunnel protocol the UDP target speaks "
                "(--eth1394, the JHU FPGA1394 protocol, is the one fw1394 knows)"
            )
        try:
            endpoint = parse_endpoint(rest)
            require_loopback(endpoint.host)
        except (AddressRefusedError, ValueError) as error:
            raise ValueError(f"{text!r}: {error}") from None
        return TargetSpec("udp", endpoint=endpoint)
    raise ValueError(f"{text!r}: expected virtual, bus:NAME/NODE or udp:HOST[:PORT]")


@contextmanager
def open_target(
    spec: TargetSpec,
    *,
    board: str = "snake2010",
    board_id: int | None = None,
    peer_cpus: set[int] | None = None,
    timeout: float = 60.0,
) -> Iterator[tuple[Target, PrivateBus | None]]:
    """The target, and the bench's own bus when the target is on one (else None)."""
    if spec.kind == VIRTUAL:
        with PrivateBus(board, cpus=peer_cpus, timeout=timeout) as bus:
            yield BusTarget(bus.port, 0, "virtual-bus", board, bus.pids()), bus
    elif spec.kind == "bus":
        with _existing_bus(spec, timeout) as target:
            yield target, None
    else:
        assert spec.endpoint is not None
        with _eth1394(spec.endpoint, board_id) as target:
            yield target, None


@contextmanager
def _existing_bus(spec: TargetSpec, timeout: float) -> Iterator[BusTarget]:
    try:
        port = BusPort(
            BusConfig(spec.bus),
            timing=TIMING,
            ack_timeout=TRANSACTION_TIMEOUT_S,
            split_timeout=TRANSACTION_TIMEOUT_S,
            join_timeout=timeout,
        )
    except (OSError, ValueError) as error:
        raise TargetUnavailable(f"cannot join bus {spec.bus!r}: {error}") from None
    with port:
        try:
            nodes = dict(port.nodes())
        except BusError as error:
            raise TargetUnavailable(str(error)) from None
        if spec.node not in nodes:
            known = ", ".join(str(phy) for phy in sorted(nodes)) or "none"
            raise TargetUnavailable(
                f"no node {spec.node} on bus {spec.bus!r} (nodes: {known}; "
                "is it up? fw1394 bus up --name NAME --nodes N)"
            )
        port.poll(SETTLE_S)  # our own join was a bus reset; let it settle
        board, pids = bus_node_board(spec.bus, nodes[spec.node].pid)
        yield BusTarget(port, spec.node, "bus", board, pids)


@contextmanager
def _eth1394(endpoint: Endpoint, board_id: int | None) -> Iterator[Eth1394Target]:
    with EthUdpClient(endpoint) as client:
        scan = start(client)
        if not scan.ok:
            raise TargetUnavailable(
                f"no board answered at {endpoint} (is a server up? fw1394 jhu serve "
                f"--eth1394 {endpoint})"
            )
        chosen = scan.boards[0] if board_id is None else None
        for found in scan.boards:
            if found.board_id == board_id:
                chosen = found
        if chosen is None:
            ids = ", ".join(str(found.board_id) for found in scan.boards)
            raise TargetUnavailable(f"no board {board_id} at {endpoint} (boards: {ids})")
        yield Eth1394Target(client, chosen.node, chosen.board_id, chosen.firmware, scan.bridge)
