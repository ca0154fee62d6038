"""A QLA board process on the virtual 1394 bus, optionally cabled to the host by Eth1394.

Like an ordinary node process (:mod:`fw1394.node.process`) it answers the
1394 requests addressed to it; like the JHU firmware it also broadcasts its
real-time block on the bus after a broadcast query naming it. With an
Ethernet port (``--eth1394``) it is also what the host talks to:

* bridge mode (firmware < 9): the hub. Requests for other FireWire node IDs
  go on the bus as they arrived, and the responses addressed to the host come
  back to it with their real CRCs; broadcast writes are done locally and
  broadcast on the bus; the bus generation is checked both ways;
* Ethernet-only mode (firmware >= 9, run in a network namespace): every
  board has its own port at base + board ID, and the blocks of a broadcast
  query are exchanged over the virtual bus (the real boards use raw
  Ethernet multicast for this; the content is the same).

In ``fw1394 bus up`` the node of rank 0 is the Ethernet hub; before
firmware 9 only it is cabled to the host.
"""

from __future__ import annotations

import argparse
import select
import signal
import socket
import sys
import time
from dataclasses import dataclass
from types import FrameType

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.eth_server import (
    MAX_DATAGRAM,
    check_multicast_allowed,
    join_loopback_multicast,
    open_udp,
    send_loopback,
)
from fw1394.boards.qla1.ethernet import Action, EthernetPort, Forward, HubBroadcast, Reply, datagram
from fw1394.boards.qla1.firewire import (
    LOCAL_BUS_IDS,
    ClockedBoard,
    broadcast_sequence,
    is_hub_query,
)
from fw1394.engine import JHU_FIRMWARE
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.responder import decode_received
from fw1394.packets import BlockWriteRequest, Request, Response
from fw1394.packets.eth1394 import MULTICAST_GROUP
from fw1394.packets.fast import encode_packet
from fw1394.transport.config import BusConfig
from fw1394.transport.eth1394_addresses import (
    MULTICAST_FIRMWARE,
    Endpoint,
    board_address,
    classful_broadcast,
    parse_endpoint,
    require_loopback,
)
from fw1394.transport.faults import FaultConfig
from fw1394.transport.membership import BusReset, Refused, Timing
from fw1394.transport.station import Station
from fw1394.transport.wire import (
    BROADCAST_PHY,
    AckPayload,
    FrameHeader,
    FrameKind,
    ack_byte,
    parse_ack,
)

POLL = 0.005


class StationLink:
    """The bus as the board's Ethernet path sees it."""

    def __init__(self, station: Station) -> None:
        self._station = station

    @property
    def node_id(self) -> int:
        phy = self._station.phy_id
        return 0 if phy is None else phy

    @property
    def generation(self) -> int:
        return self._station.generation & 0xFF

    @property
    def resetting(self) -> bool:
        # Between leaving one generation and taking part in the next.
        return self._station.phy_id is None


@dataclass
class BusNodeOptions:
    config: BusConfig
    rank: int | None = None
    timing: Timing | None = None
    faults: FaultConfig | None = None
    #: Where the host reaches this board; None: no Ethernet cable.
    eth1394: Endpoint | None = None
    ethernet_hub: bool = True
    #: Planted packet-level bugs for the fuzzer (fw1394.engine.defects).
    defects: frozenset[str] = frozenset()


class QlaBusNode:
    """One QLA board: a bus station, a responder, and maybe an Ethernet port."""

    def __init__(self, board: Qla1Board, options: BusNodeOptions) -> None:
        self.board = board
        self.station = Station(
            options.config,
            rank=options.rank,
            board_id=board.board_id,
            timing=options.timing,
            faults=options.faults,
            drop_acks=False,  # forwarded requests are answered in ack frames
        )
        self.responder = DefectiveResponder(
            LOCAL_BUS_IDS | 63, ClockedBoard(board), JHU_FIRMWARE, defects=options.defects
        )
        self.port = EthernetPort(
            board, self.responder, StationLink(self.station), ethernet_hub=options.ethernet_hub
        )
        self.epoch = time.monotonic()
        self._running = True
        self._unicast: socket.socket | None = None
        self._udp: list[socket.socket] = []
        if options.eth1394 is not None:
            try:
                self._open(options.eth1394)
            except OSError:
                self.close()
                raise

    def _open(self, endpoint: Endpoint) -> None:
        base = require_loopback(endpoint.host)
        firmware = self.board.firmware
        check_multicast_allowed(firmware)
        address = require_loopback(board_address(base, self.board.board_id, firmware))
        self._unicast = open_udp(address, endpoint.port)
        self._udp = [self._unicast, open_udp(classful_broadcast(base), endpoint.port)]
        if firmware >= MULTICAST_FIRMWARE:
            group = open_udp(MULTICAST_GROUP, endpoint.port)
            self._udp.append(group)
            join_loopback_multicast(group)

    @property
    def addresses(self) -> list[str]:
        return [f"{host}:{port}" for host, port in (s.getsockname() for s in self._udp)]

    def now(self) -> float:
        return time.monotonic() - self.epoch

    def stop(self) -> None:
        self._running = False

    def close(self) -> None:
        for sock in self._udp:
            sock.close()
        self._udp = []

    # -- the loop -------------------------------------------------------------------------
    def run(self) -> None:
        station = self.station
        medium = station.medium.sock
        try:
            due = 0.0
            while self._running:
                wait = min(POLL, max(0.0, due - time.monotonic()))
                if (deadline := self.port.next_deadline()) is not None:
                    wait = min(wait, max(0.0, deadline - self.now()))
                readable, _, _ = select.select([medium, *self._udp], [], [], wait)
                actions: list[Action] = []
                for sock in readable:
                    if sock is medium:
                        actions += self._bus_frame()
                    else:
                        actions += self._datagrams(sock)
                actions += self.port.poll(self.now())
                self._carry_out(actions)
                self._apply_changes()
                if time.monotonic() >= due:
                    station.service()
                    self._apply_changes()
                    due = station.next_deadline()
        finally:
            try:
                station.close()
            finally:
                self.close()

    def _apply_changes(self) -> None:
        for change in self.station.changes():
            if isinstance(change, BusReset):
                self.responder.bus_reset(LOCAL_BUS_IDS | change.phy_id, change.generation)
                self.board.set_physical_id(change.phy_id)
            elif isinstance(change, Refused):
                raise RuntimeError(f"the bus refused this node: {change.reason}")

    def _datagrams(self, sock: socket.socket) -> list[Action]:
        actions: list[Action] = []
        while True:
            try:
                payload, sender = sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return actions
            actions += self.port.receive(payload, sender, self.now())

    def _bus_frame(self) -> list[Action]:
        station = self.station
        frame = station.receive()
        if frame is None or station.phy_id is None:
            return []
        header, payload = frame
        if header.generation != station.generation:
            return []  # a packet of another generation never reaches a link after a reset
        if header.kind == FrameKind.ack:
            concatenated = parse_ack(payload).concatenated
            return self.port.firewire_response(concatenated, self.now()) if concatenated else []
        if header.kind == FrameKind.async_packet:
            return self._bus_packet(header, payload)
        return []

    def _bus_packet(self, header: FrameHeader, payload: bytes) -> list[Action]:
        now = self.now()
        packet, damaged = decode_received(payload)
        if isinstance(packet, Response):
            return self.port.firewire_response(payload, now)
        if (
            isinstance(packet, BlockWriteRequest)
            and packet.destination_node == BROADCAST_PHY
            and broadcast_sequence(packet) is not None
        ):
            return self.port.hub_block(packet, now)  # another board's block, for the hub
        if not isinstance(packet, Request):
            return []
        reply = self.responder.receive_packet(packet, now, damaged=damaged)
        if reply.ack is not None:
            response = b"" if reply.response is None else encode_packet(reply.response)
            tlabel = packet.tlabel
            if reply.concatenated or not response:
                ack = AckPayload(ack_byte(reply.ack), tlabel, header.sequence, response)
                self.station.send(FrameKind.ack, header.sender_phy, ack.pack())
            else:
                ack = AckPayload(ack_byte(reply.ack), tlabel, header.sequence)
                self.station.send(FrameKind.ack, header.sender_phy, ack.pack())
                self.station.send(FrameKind.async_packet, header.sender_phy, response)
        if is_hub_query(packet) and packet.destination_node in (0, BROADCAST_PHY):
            return self.port.query_taken(now)
        return []

    def _carry_out(self, actions: list[Action]) -> None:
        processed = self.now()
        for action in actions:
            if isinstance(action, Reply):
                if self._unicast is not None:
                    payload = datagram(action, processed, self.now())
                    send_loopback(self._unicast, payload, action.address)
            elif isinstance(action, Forward):
                self.station.send(
                    FrameKind.async_packet, action.packet.destination_node, action.raw
                )
            elif isinstance(action, HubBroadcast):
                self.station.send(
                    FrameKind.async_packet, BROADCAST_PHY, encode_packet(action.packet)
                )


# -- command-line glue for ``fw1394 node run`` / ``fw1394 bus up`` --------------------------


def add_eth1394_options(parser: argparse.ArgumentParser) -> None:
    """``--eth1394 [ADDRESS[:PORT]]`` and ``--firmware`` (qla1 boards)."""
    group = parser.add_argument_group("JHU Eth1394 (qla1 boards)")
    group.add_argument(
        "--eth1394",
        nargs="?",
        const="127.0.0.1",
        default=None,
        metavar="ADDRESS[:PORT]",
        help="cable the board to a host at this loopback server IP (default 127.0.0.1:1394)",
    )
    group.add_argument(
        "--firmware",
        type=int,
        default=8,
        help="qla1 firmware revision (default 8: bridge mode; >= 9 needs a network namespace)",
    )


def eth1394_node_arguments(args: argparse.Namespace) -> tuple[str, ...]:
    """The options above again, for ``bus up`` to hand to its node processes.

    Raises ValueError (with the reason) for a setting no node could start with.
    """
    if args.board != "qla1":
        if args.eth1394 is not None:
            raise ValueError(f"--eth1394 needs --board qla1, not {args.board}")
        return ()
    out: tuple[str, ...] = ("--firmware", str(args.firmware))
    if args.eth1394 is not None:
        require_loopback(parse_endpoint(args.eth1394).host)
        check_multicast_allowed(args.firmware)
        out += ("--eth1394", args.eth1394)
    return out


def run_from_arguments(
    args: argparse.Namespace,
    config: BusConfig,
    timing: Timing | None,
    faults: FaultConfig | None,
) -> None:
    """Run the qla1 board of ``fw1394 node run`` until SIGINT or SIGTERM."""
    from fw1394.boards.registry import board_defects, check_defects

    defects = check_defects("qla1", getattr(args, "defect", None) or [])
    board = Qla1Board(
        board_id=args.board_id, firmware=args.firmware, defects=board_defects("qla1", defects)
    )
    # In a bus of several processes the first one is the board nearest the host;
    # before firmware 9 it is also the only one with an Ethernet cable.
    hub = args.rank in (None, 0)
    cabled = args.eth1394 is not None and (hub or args.firmware >= MULTICAST_FIRMWARE)
    options = BusNodeOptions(
        config=config,
        rank=args.rank,
        timing=timing,
        faults=faults,
        eth1394=parse_endpoint(args.eth1394) if cabled else None,
        ethernet_hub=hub,
        defects=defects,
    )
    node = QlaBusNode(board, options)
    if node.addresses and not args.quiet:
        print(
            f"fw1394 node: board {board.board_id} on {', '.join(node.addresses)}", file=sys.stderr
        )

    def stop(signum: int, frame: FrameType | None) -> None:
        node.stop()

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        node.run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
