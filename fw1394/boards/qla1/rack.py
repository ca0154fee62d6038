"""Several QLA boards in one process: an in-process FireWire bus and their Ethernet ports.

Board ``n`` of the rack has physical ID ``n`` on the in-process bus. Which
boards have an Ethernet port depends on the firmware, as on a real setup:
before firmware 9 only the hub (board 0 of the rack) is cabled to the host
and the others are reached through it over FireWire (bridge mode); from
firmware 9 on every board has its own address, the first being the hub
(the board nearest the host). Everything is synchronous: a forwarded request
is answered, and a hub broadcast delivered, before :meth:`Rack.receive`
returns. A datagram for every port (:meth:`Rack.receive_everywhere`) that is
the host's real-time cycle is served for all boards in one pass
(:mod:`fw1394.boards.qla1.rack_fast`).
"""

from __future__ import annotations

from collections import deque
from collections.abc import Sequence

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.ethernet import (
    Action,
    EthernetPort,
    Forward,
    HostAddress,
    HubBroadcast,
    Reply,
)
from fw1394.boards.qla1.firewire import (
    ClockedBoard,
    as_snooped,
    hub_broadcast,
    reaches_every_node,
    takes_query,
)
from fw1394.boards.qla1.rack_fast import RackFastPath
from fw1394.boards.qla1.rack_member import BusState, RackBoard, RackLink
from fw1394.engine import JHU_FIRMWARE, Responder
from fw1394.packets import BlockWriteRequest, Request, Response
from fw1394.packets.eth1394 import Eth1394Error
from fw1394.packets.eth1394_fast import split_request
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.packets.nodeid import node_id as node_id_of
from fw1394.transport.eth1394_addresses import MULTICAST_FIRMWARE


class Rack:
    """Boards ``board_ids`` (in physical-ID order) with ``firmware`` and ``fpga_version``."""

    def __init__(
        self,
        board_ids: Sequence[int],
        *,
        firmware: int = 8,
        fpga_version: int = 3,
        git_description: int = 0,
    ) -> None:
        if not board_ids:
            raise ValueError("a rack needs at least one board")
        if len(set(board_ids)) != len(board_ids):
            raise ValueError(f"board IDs {list(board_ids)} repeat")
        self.firmware = firmware
        self.bus = BusState()
        self.members: list[RackBoard] = []
        for node, board_id in enumerate(board_ids):
            board = Qla1Board(
                board_id=board_id,
                firmware=firmware,
                fpga_version=fpga_version,
                git_description=git_description,
                physical_id=node,
            )
            responder = Responder(node_id_of(node), ClockedBoard(board), JHU_FIRMWARE)
            cabled = node == 0 or firmware >= MULTICAST_FIRMWARE
            port = (
                EthernetPort(
                    board,
                    responder,
                    RackLink(self.bus, node),
                    ethernet_hub=node == 0,
                    # Boards in one rack exchange their blocks before a request returns:
                    # a hub read is answered at once, as the firmware does.
                    hub_read_wait=0.0,
                )
                if cabled
                else None
            )
            self.members.append(RackBoard(board, responder, port))
        self._cabled = [(n, m.port) for n, m in enumerate(self.members) if m.port is not None]
        #: The one-pass path for the host's real-time cycle; None: every datagram is
        #: served the general way (the reference the tests hold it equal to).
        self.fast_path: RackFastPath | None = RackFastPath(self.members, firmware)

    @property
    def ports(self) -> list[tuple[int, EthernetPort]]:
        """(index, port) of the boards cabled to the host."""
        return list(self._cabled)

    def bus_reset(self) -> None:
        """A FireWire bus reset: the generation moves on (node IDs stay as they are)."""
        self.bus.generation = (self.bus.generation + 1) & 0xFF

    # -- traffic ------------------------------------------------------------------------
    def receive(
        self, index: int, payload: bytes, sender: HostAddress, now: float
    ) -> list[tuple[int, Reply]]:
        """A datagram for the port of board ``index``; the replies it causes, by port."""
        port = self.members[index].port
        if port is None:
            return []
        try:
            framed = split_request(payload)
        except Eth1394Error:
            return []  # never "fresh": ignored
        if self.fast_path is not None and port.ethernet_hub:
            replies = self.fast_path.bridge_framed(framed, sender, now, self.bus.resetting)
            if replies is not None:
                return replies
        return self._run(index, port.receive_framed(framed, sender, now), now)

    def receive_everywhere(
        self, payload: bytes, sender: HostAddress, now: float
    ) -> list[tuple[int, Reply]]:
        """A datagram every cabled port gets (the host's broadcast or multicast), port by
        port in index order; the host's real-time cycle in one pass (:mod:`.rack_fast`)."""
        if self.fast_path is not None:
            replies = self.fast_path.receive(payload, sender, now)
            if replies is not None:
                return replies
        replies = []
        for index, _ in self._cabled:
            replies += self.receive(index, payload, sender, now)
        return replies

    def poll(self, now: float) -> list[tuple[int, Reply]]:
        replies: list[tuple[int, Reply]] = []
        for index, port in self._cabled:
            actions = port.poll(now)
            if actions:
                replies += self._run(index, actions, now)
        return replies

    def next_deadline(self) -> float | None:
        soonest = None
        for _, port in self._cabled:
            due = port.next_deadline()
            if due is not None and (soonest is None or due < soonest):
                soonest = due
        return soonest

    def _run(self, origin: int, actions: list[Action], now: float) -> list[tuple[int, Reply]]:
        queue: deque[tuple[int, Action]] = deque((origin, action) for action in actions)
        replies: list[tuple[int, Reply]] = []
        while queue:
            source, action = queue.popleft()
            if isinstance(action, Reply):
                replies.append((source, action))
            elif isinstance(action, Forward):
                queue.extend(self._forward(source, action.packet, now))
            elif isinstance(action, HubBroadcast):
                queue.extend(self._share(source, action.packet, now))
        return replies

    def _forward(self, source: int, packet: Request, now: float) -> list[tuple[int, Action]]:
        """Deliver ``packet`` on the bus from board ``source``; what follows from it."""
        if reaches_every_node(packet):
            targets = [n for n in range(len(self.members)) if n != source]
        else:
            targets = [
                n for n, m in enumerate(self.members) if m.node_id == packet.destination_node
            ]
        damaged = bool(packet.problems)
        origin_port = self.members[source].port
        follow: list[tuple[int, Action]] = []
        for target in targets:
            member = self.members[target]
            named = packet.destination_node in (member.node_id, BROADCAST_PHY)
            seen = packet if named else as_snooped(packet)
            reply = member.responder.receive_packet(seen, now, damaged=damaged)
            if isinstance(reply.response, Response) and origin_port is not None:
                raw = encode_packet(reply.response)  # a FireWire node's response: real CRCs
                follow += [(source, a) for a in origin_port.firewire_response(raw, now)]
            if takes_query(packet, member.board.firmware):
                follow += self._after_query(target, now)
        return follow

    def _after_query(self, index: int, now: float) -> list[tuple[int, Action]]:
        member = self.members[index]
        if member.port is not None:
            return [(index, a) for a in member.port.query_taken(now)]
        block = hub_broadcast(member.board, member.node_id)
        return [] if block is None else [(index, HubBroadcast(block))]

    def _share(
        self, source: int, packet: BlockWriteRequest, now: float
    ) -> list[tuple[int, Action]]:
        follow: list[tuple[int, Action]] = []
        for index, member in enumerate(self.members):
            if index == source:
                continue
            if member.port is not None:
                follow += [(index, a) for a in member.port.hub_block(packet, now)]
            else:
                member.responder.receive_packet(packet, now, damaged=False)
        return follow
