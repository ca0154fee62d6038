"""``bus:NAME/NODE``: one node of a virtual 1394 bus, fuzzed from a host member.

The fuzzer joins the bus as a host (a bus reset; boards keep their physical
IDs) and sends every case in a frame addressed to the node's physical ID,
whatever 1394 destination the packet names: the node's link sees every packet
on a real bus too, and what it does with a packet for someone else is part of
the test. Replies are the node's acks and responses (``docs/virtual-bus.md``).
"""

from __future__ import annotations

import time

from fw1394.fuzz.target import Observed, TargetCrash, TargetGone, Wire
from fw1394.fuzz.tunnel import Replies
from fw1394.fuzz.udptarget import TUNNEL_VISIBILITY
from fw1394.transport.config import BusConfig, BusNameError
from fw1394.transport.procs import pid_namespace, process_alive
from fw1394.transport.station import Station
from fw1394.transport.wire import FrameKind, MemberInfo

LOCAL_BUS = 0x3FF
_POLL = 0.002
_JOIN_TIMEOUT = 10.0
_DATA_KINDS = frozenset({FrameKind.ack, FrameKind.async_packet})


class BusTarget:
    """Physical node ``phy`` of the bus ``config``."""

    visibility = TUNNEL_VISIBILITY
    needs_fence = True
    restartable = False

    def __init__(self, config: BusConfig, phy: int, timeout: float) -> None:
        self.description = f"bus:{config.name}/{phy}"
        self.timeout = timeout
        self.phy = phy
        self.node_id = LOCAL_BUS << 6 | phy
        self.station = Station(config, contender=True, host=True, poll_interval=_POLL)
        self._due = 0.0
        try:
            self.member = self._join()
        except BaseException:
            self.station.close()
            raise

    @classmethod
    def open(cls, spec: str, *, timeout: float) -> BusTarget:
        """``spec`` is ``NAME/NODE``: a bus name and a physical ID."""
        name, slash, node = spec.rpartition("/")
        if not slash or not node.isdigit() or not 0 <= int(node) < 63:
            raise TargetGone(f"bus target {spec!r}: use bus:NAME/NODE, NODE a physical ID 0-62")
        try:
            config = BusConfig(name or "default")
        except (BusNameError, ValueError) as error:
            raise TargetGone(str(error)) from None
        return cls(config, int(node), timeout)

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
            self._pump()

    def _pump(self) -> tuple[int, int, bytes] | None:
        """One frame from the node (kind, sequence, payload), after any bus housekeeping."""
        station = self.station
        frame = station.receive()
        if frame is None or frame[0].kind not in _DATA_KINDS:
            # Bus management went by (or nothing): bus resets are judged by problem(),
            # from the member table, so the changes themselves are not needed.
            station.changes()
        now = time.monotonic()
        if now >= self._due:
            station.service(now)
            station.changes()
            self._due = station.next_deadline()
        if frame is None:
            return None
        header, payload = frame
        if header.sender_phy != self.phy or header.generation != station.generation:
            return None
        return header.kind, header.sequence, payload

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        station = self.station
        sequences = [station.send(FrameKind.async_packet, self.phy, wire.raw) for wire in batch]
        replies = Replies(batch, sequences)
        limit = time.monotonic() + self.timeout
        while not replies.complete() and time.monotonic() < limit:
            frame = self._pump()
            if frame is None:
                continue
            kind, _, payload = frame
            if kind == FrameKind.ack:
                replies.on_ack(payload)
            elif kind == FrameKind.async_packet:
                replies.on_response(payload)
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
