"""``bus:NAME/NODE``: one node of a virtual 1394 bus, fuzzed from a host member.

The fuzzer joins the bus as a host (a bus reset; boards keep their physical
IDs) and sends every case in a frame addressed to the node's physical ID,
whatever 1394 destination the packet names: the node's link sees every packet
on a real bus too, and what it does with a packet for someone else is part of
the test. Replies are the node's acks and responses (``docs/virtual-bus.md``).
"""

from __future__ import annotations

import time

from fw1394.fuzz.reference import RomIdentity
from fw1394.fuzz.target import Observed, TargetCrash, TargetGone, Wire
from fw1394.fuzz.tunnel import Replies
from fw1394.fuzz.udptarget import TUNNEL_VISIBILITY
from fw1394.packets.nodeid import node_id
from fw1394.transport.link import ACK, ASYNC_PACKET, BusRefusedError, LinkLayer
from fw1394.transport.sansio.config import BusConfig, BusNameError
from fw1394.transport.sansio.wire import FrameHeader, MemberInfo
from fw1394.transport.station import Station
from fw1394.transport.supervision.procs import pid_namespace, process_alive

_POLL = 0.002
_JOIN_TIMEOUT = 10.0


class NodeLink(LinkLayer):
    """The fuzzer's link: keeps what physical ID ``phy`` sends, for :class:`Replies`.

    Bus resets reach no engine here: :meth:`BusTarget.problem` judges them from
    the member table.
    """

    def __init__(self, station: Station, phy: int) -> None:
        super().__init__(station.send, station)
        self.phy = phy
        #: (kind, payload) of each ack or packet from the node, oldest first.
        self.frames: list[tuple[int, bytes]] = []

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if header.sender_phy == self.phy and header.kind in (ACK, ASYNC_PACKET):
            self.frames.append((header.kind, payload))


class BusTarget:
    """Physical node ``phy`` of the bus ``config``."""

    visibility = TUNNEL_VISIBILITY
    needs_fence = True
    restartable = False

    def __init__(self, config: BusConfig, phy: int, timeout: float) -> None:
        self.description = f"bus:{config.name}/{phy}"
        self.bus_name = config.name
        self.timeout = timeout
        self.phy = phy
        self.node_id = node_id(phy)
        self.station = Station(config, contender=True, host=True, poll_interval=_POLL)
        self.link = NodeLink(self.station, phy)
        try:
            self.member = self._join()
        except BusRefusedError as error:
            self.station.close()
            raise TargetGone(f"{self.description}: the bus refused the fuzzer: {error}") from None
        except BaseException:
            self.station.close()
            raise

    @classmethod
    def open(cls, name: str, node: int, *, timeout: float) -> BusTarget:
        """Physical ID ``node`` of the bus ``name`` (parsed by :func:`targets.bus_node`)."""
        try:
            config = BusConfig(name)
        except (BusNameError, ValueError) as error:
            raise TargetGone(str(error)) from None
        return cls(config, node, timeout)

    def _join(self) -> MemberInfo:
        """Wait until the bus, with a node at our physical ID, is ready."""
        station = self.station
        limit = time.monotonic() + _JOIN_TIMEOUT
        while True:
            membership = station.membership
            members = membership.members
            there = self.phy < len(members) and members[self.phy].member_id != station.member_id
            if membership.ready and there:
                return members[self.phy]
            if time.monotonic() > limit:
                what = "no node with that physical ID" if membership.ready else "no bus heard"
                raise TargetGone(f"{self.description}: {what} within {_JOIN_TIMEOUT} s")
            self.link.turn()
            self.link.frames.clear()

    def rom_identity(self) -> RomIdentity:
        """What the node's configuration ROM is made from: its bus, board ID and rank."""
        return RomIdentity(self.bus_name, self.member.board_id, self.member.rank)

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        link, frames = self.link, self.link.frames
        frames.clear()  # whatever came late for an earlier batch
        sequences = [self.station.send(ASYNC_PACKET, self.phy, wire.raw) for wire in batch]
        replies = Replies(batch, sequences)
        limit = time.monotonic() + self.timeout
        while not replies.complete() and time.monotonic() < limit:
            link.turn()
            for kind, payload in frames:
                if kind == ACK:
                    replies.on_ack(payload)
                else:
                    replies.on_response(payload)
            frames.clear()
        if not replies.complete():
            problem = self.problem()
            if problem is not None:
                raise TargetCrash(problem)
        return list(replies.observations())

    def problem(self) -> str | None:
        members = self.station.membership.members
        ids = [m.member_id for m in members]
        member = self.member
        if member.member_id not in ids:
            if self._local(member) and not process_alive(member.pid):
                return f"process-gone: node process {member.pid} has exited"
            return "left-bus: the node is no longer a member of the bus"
        if ids.index(member.member_id) != self.phy:
            return f"renumbered: the node is now physical ID {ids.index(member.member_id)}"
        if self._local(member) and not process_alive(member.pid):
            return f"process-gone: node process {member.pid} has exited"
        return None

    def _local(self, member: MemberInfo) -> bool:
        me = self.station.info
        return member.address == me.address and member.pid_namespace == pid_namespace()

    def restart(self) -> None:
        raise TargetGone(f"{self.description} cannot be restarted from here")

    def close(self) -> None:
        self.station.close()
