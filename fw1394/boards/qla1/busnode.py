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

import select
import socket
import sys
import time
from dataclasses import dataclass

from fw1394.boards.qla1.board import BOARD_DEFECTS, Qla1Board
from fw1394.boards.qla1.eth_server import (
    MAX_DATAGRAM,
    RefusalLog,
    check_multicast_allowed,
    join_loopback_multicast,
    open_udp,
    reply_address,
    send_loopback,
)
from fw1394.boards.qla1.ethernet import Action, EthernetPort, Forward, HubBroadcast, Reply, datagram
from fw1394.boards.qla1.firewire import (
    ClockedBoard,
    as_snooped,
    broadcast_sequence,
    reaches_every_node,
    takes_query,
)
from fw1394.engine import JHU_FIRMWARE, Responder
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.faults import FaultConfig
from fw1394.engine.responder import decode_received
from fw1394.packets import BlockWriteRequest, Request, Response
from fw1394.packets.eth1394 import MULTICAST_GROUP
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import BROADCAST_ID, BROADCAST_PHY
from fw1394.transport.eth1394_addresses import (
    MULTICAST_FIRMWARE,
    Endpoint,
    board_address,
    classful_broadcast,
    parse_endpoint,
    require_loopback,
)
from fw1394.transport.link import ACK, ASYNC_PACKET, ResponderLink
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import BusReset, Timing
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, parse_ack
from fw1394.transport.station import Station
from fw1394.transport.supervision.procs import run_until_signalled

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


class BoardLink(ResponderLink):
    """The board's link: requests go to its responder, and what the Ethernet port
    waits for (responses to forwarded requests, other boards' blocks) to the port.

    The port's answers collect in :attr:`actions` for the node to carry out.
    """

    def __init__(self, responder: Responder, station: Station, port: EthernetPort) -> None:
        super().__init__(responder, station.send, station, epoch=time.monotonic())
        self.port = port
        self.actions: list[Action] = []

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        board_now = now - self.epoch
        kind = header.kind
        if kind == ACK:
            concatenated = parse_ack(payload).concatenated
            if concatenated:
                self.actions += self.port.firewire_response(concatenated, board_now)
            return
        if kind != ASYNC_PACKET:
            return
        packet, damaged = decode_received(payload)
        if isinstance(packet, Response):
            self.actions += self.port.firewire_response(payload, board_now)
        elif (
            isinstance(packet, BlockWriteRequest)
            and packet.destination_node == BROADCAST_PHY
            and broadcast_sequence(packet) is not None
        ):
            self.actions += self.port.hub_block(packet, board_now)  # another board's block
        elif isinstance(packet, Request):
            own = self.port.firewire.node_id
            every = reaches_every_node(packet)
            repeated = header.destination == BROADCAST_PHY
            if every and packet.destination_node == own:
                if repeated:
                    return  # this board's own repeat of a packet it took already
                # On a real bus every node sees every packet and the boards snoop these;
                # the virtual bus brings a packet to its addressee only, so the addressee
                # repeats it to the others (before its own hub broadcast follows).
                self._station().send(FrameKind.async_packet, BROADCAST_PHY, payload)
            if every and packet.destination_node not in (own, BROADCAST_PHY):
                packet = as_snooped(packet)
            self.serve_packet(packet, damaged, header.sender_phy, header.sequence, now)
            if takes_query(packet, self.port.board.firmware) and (
                every or packet.destination_node == own
            ):
                self.actions += self.port.query_taken(board_now)


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
            BROADCAST_ID, ClockedBoard(board), JHU_FIRMWARE, defects=options.defects
        )
        self.port = EthernetPort(
            board, self.responder, StationLink(self.station), ethernet_hub=options.ethernet_hub
        )
        self.link = BoardLink(self.responder, self.station, self.port)
        self.link.on_reset = self._on_reset
        self.epoch = self.link.epoch
        self._running = True
        self.refusals = RefusalLog()
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
        # The board's own address is its alone; the broadcast and multicast sockets are
        # shared with the other boards of the bus.
        self._unicast = open_udp(address, endpoint.port, exclusive=True)
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
        station, link = self.station, self.link
        medium = station.medium.sock
        try:
            while self._running:
                wait = min(POLL, max(0.0, link.due - time.monotonic()))
                if (deadline := self.port.next_deadline()) is not None:
                    wait = min(wait, max(0.0, deadline - self.now()))
                readable, _, _ = select.select([medium, *self._udp], [], [], wait)
                for sock in readable:
                    if sock is medium:
                        if (frame := station.receive()) is not None:
                            link.receive(frame[0], frame[1], time.monotonic())
                    else:
                        link.actions += self._datagrams(sock)
                actions, link.actions = link.actions, []
                self._carry_out(actions + self.port.poll(self.now()))
                link.apply_changes()
                if time.monotonic() >= link.due:
                    link.service()
        finally:
            try:
                station.close()
            finally:
                self.close()

    def _on_reset(self, change: BusReset) -> None:
        self.board.set_physical_id(change.phy_id)

    def _datagrams(self, sock: socket.socket) -> list[Action]:
        actions: list[Action] = []
        while True:
            try:
                payload, sender = sock.recvfrom(MAX_DATAGRAM)
            except (BlockingIOError, InterruptedError):
                return actions
            actions += self.port.receive(payload, sender, self.now())

    def _carry_out(self, actions: list[Action]) -> None:
        processed = self.now()
        for action in actions:
            if isinstance(action, Reply):
                if self._unicast is not None:
                    payload = datagram(action, processed, self.now())
                    local = self._unicast.getsockname()[0]
                    address = reply_address(action.address, local)
                    cause = send_loopback(self._unicast, payload, address)
                    if cause is not None:
                        self.refusals.refused(action.address, cause)
            elif isinstance(action, Forward):
                self.station.send(
                    FrameKind.async_packet, action.packet.destination_node, action.raw
                )
            elif isinstance(action, HubBroadcast):
                self.station.send(
                    FrameKind.async_packet, BROADCAST_PHY, encode_packet(action.packet)
                )


# -- the node program (fw1394.boards.registry: qla1's node_program) ----------------------------
class Qla1NodeProgram:
    """How ``python -m fw1394.node`` runs a qla1 node: with its Ethernet side."""

    def check(self, *, eth1394: str | None, firmware: int) -> None:
        if eth1394 is not None:
            require_loopback(parse_endpoint(eth1394).host)
            check_multicast_allowed(firmware)

    def run(
        self,
        *,
        config: BusConfig,
        board_id: int,
        rank: int | None,
        timing: Timing | None,
        faults: FaultConfig | None,
        defects: frozenset[str],
        eth1394: str | None,
        firmware: int,
        quiet: bool,
    ) -> None:
        """Run the board until SIGINT or SIGTERM; ValueError or OSError if it cannot start."""
        self.check(eth1394=eth1394, firmware=firmware)
        board = Qla1Board(board_id=board_id, firmware=firmware, defects=defects & BOARD_DEFECTS)
        # In a bus of several processes the first one is the board nearest the host;
        # before firmware 9 it is also the only one with an Ethernet cable.
        hub = rank in (None, 0)
        cabled = eth1394 is not None and (hub or firmware >= MULTICAST_FIRMWARE)
        options = BusNodeOptions(
            config=config,
            rank=rank,
            timing=timing,
            faults=faults,
            eth1394=parse_endpoint(eth1394) if cabled and eth1394 else None,
            ethernet_hub=hub,
            defects=defects,
        )
        node = QlaBusNode(board, options)
        if node.addresses and not quiet:
            print(
                f"fw1394 node: board {board.board_id} on {', '.join(node.addresses)}",
                file=sys.stderr,
            )

        run_until_signalled(node.run, node.stop)


QLA1_NODE = Qla1NodeProgram()
