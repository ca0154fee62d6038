"""The shared medium: one UDP socket in the bus's multicast groups.

Every member sends each frame once; the kernel copies it to the member sockets
of its group (on loopback, and over a LAN with ``ttl`` >= 1), which is what a
1394 PHY's repeating of every packet gives a real bus. A frame for every member
or for broadcast goes to the bus group, which every member joins; a frame
addressed to one node goes to that node's shard group
(:data:`~fw1394.transport.sansio.config.SHARDS`), which only its shard's members and
the taps join: the kernel then copies it to a few sockets instead of all 63,
and the link's filter (:mod:`fw1394.transport.media.bpf`) drops the shard's others.
A tap joins every group on one socket, so it still reads the bus as one
stream in the order the kernel took the frames.
"""

from __future__ import annotations

import socket
import struct
import time
from collections.abc import Callable

from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.transport.media import bpf
from fw1394.transport.media.idle import BLOCK, IdleStrategy, Waiter, set_receive_timeout
from fw1394.transport.sansio.config import SHARDS, BusConfig
from fw1394.transport.sansio.wire import CONTROL_KINDS, DESTINATION_OFFSET, KIND_OFFSET

#: Room for bursts (a 63-node self-ID phase, back-to-back block responses).
RECEIVE_BUFFER = 1 << 21
MAX_FRAME = 65_535
#: Linux: deliver only the groups this socket joined, not every group on the host.
IP_MULTICAST_ALL = 49
SO_TIMESTAMPNS = 35
_TIMESPEC = struct.Struct("@qq")
_DONTWAIT = socket.MSG_DONTWAIT
_DESTINATION = DESTINATION_OFFSET
_KIND = KIND_OFFSET
#: Frames of this kind and above manage the bus: they expect no answer soon.
FIRST_CONTROL_KIND = min(CONTROL_KINDS)


class Medium:
    """A socket bound to the bus group; ``poll_interval`` bounds a blocking receive.

    ``idle`` is how :meth:`receive` waits (:mod:`fw1394.transport.media.idle`); plain
    blocking unless given, as for taps and tools that only listen.
    """

    def __init__(
        self, config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK
    ) -> None:
        self.config = config
        self.destination = (config.group, config.port)
        shards = [(group, config.port) for group in config.shard_groups]
        #: Where a frame goes, by its destination byte: a node's shard, else the bus group.
        self.destinations = tuple(
            shards[byte % SHARDS] if byte < BROADCAST_PHY else self.destination
            for byte in range(256)
        )
        #: The shard groups this socket has joined (the bus group it always has).
        self._shards: set[str] = set()
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self._configure(sock, poll_interval)
        except OSError:
            sock.close()
            raise
        self.sock = sock
        self.idle = idle
        self._waiter = Waiter(sock, idle, poll_interval, (KIND_OFFSET, FIRST_CONTROL_KIND))
        self._wait = self._waiter.receive
        self._sendto = sock.sendto
        # Sending is traffic only to a member that polls after traffic.
        self._traffic = self._waiter.traffic if idle.window else None

    def _configure(self, sock: socket.socket, poll_interval: float) -> None:
        cfg = self.config
        group = socket.inet_aton(cfg.group)
        interface = socket.inet_aton(cfg.interface)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RECEIVE_BUFFER)
        # Only the groups this socket joins come in, not every group on the host;
        # bound to no address, because one socket hears several groups.
        sock.setsockopt(socket.IPPROTO_IP, IP_MULTICAST_ALL, 0)
        sock.bind(("", cfg.port))
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, group + interface)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, interface)
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, cfg.ttl)
        # The loopback device hands every datagram back to this host by itself; the
        # extra copy IP_MULTICAST_LOOP makes would only cost time. On a LAN
        # interface the loop is what lets members on the same host hear each other.
        on_loopback = cfg.interface.startswith("127.")
        sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_LOOP, 0 if on_loopback else 1)
        self.set_poll_interval(sock, poll_interval)

    @staticmethod
    def set_poll_interval(sock: socket.socket, seconds: float) -> None:
        set_receive_timeout(sock, seconds)

    def sleep_until(self, deadline: Callable[[], float]) -> None:
        """Block, when nothing comes, until ``deadline()`` (monotonic) rather than
        for one poll interval (:attr:`fw1394.transport.media.idle.Waiter.deadline`)."""
        self._waiter.deadline = deadline

    def share_host(self, members: int) -> None:
        """This bus has ``members`` members on this host (:meth:`Waiter.share_host
        <fw1394.transport.media.idle.Waiter.share_host>`)."""
        self._waiter.share_host(members)

    def _listen_on(self, groups: set[str]) -> None:
        # Joins first: a frame to the new address may be on its way already.
        interface = socket.inet_aton(self.config.interface)
        for option, changed in (
            (socket.IP_ADD_MEMBERSHIP, groups - self._shards),
            (socket.IP_DROP_MEMBERSHIP, self._shards - groups),
        ):
            for group in sorted(changed):
                self.sock.setsockopt(socket.IPPROTO_IP, option, socket.inet_aton(group) + interface)
        self._shards = groups

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        """Hear what a node with ``phy_id`` (0-62) hears (None: bus-wide frames only)."""
        if phy_id is not None and not 0 <= phy_id < BROADCAST_PHY:
            raise ValueError(f"physical ID {phy_id} is not a node's (0-62)")
        self._listen_on(set() if phy_id is None else {self.destinations[phy_id][0]})
        bpf.attach(self.sock, self.config.tag, member_id, phy_id, drop_acks)

    def filter_as_tap(self) -> None:
        """Hear every frame of the bus, with its kernel arrival time."""
        self._listen_on(set(self.config.shard_groups))
        bpf.attach(self.sock, self.config.tag, None, None)
        self.sock.setsockopt(socket.SOL_SOCKET, SO_TIMESTAMPNS, 1)

    def send(self, frame: bytes) -> None:
        # A full send queue is congestion on the bus: the frame is lost, as on a
        # wire; the transaction layer's retries and timeouts deal with it. A try
        # statement costs nothing here, contextlib.suppress a context manager per frame.
        try:  # noqa: SIM105
            self._sendto(frame, self.destinations[frame[_DESTINATION]])
        except (BlockingIOError, InterruptedError):
            pass
        if self._traffic is not None and frame[_KIND] < FIRST_CONTROL_KIND:
            self._traffic()  # the answer comes soon: be awake for it

    def receive(self) -> bytes | None:
        """The next frame, or None when the poll interval passes without one."""
        return self._wait(MAX_FRAME)

    def receive_queued(self) -> bytes | None:
        """The next frame already queued, or None at once if there is none."""
        try:
            return self.sock.recv(MAX_FRAME, socket.MSG_DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return None

    def receive_stamped(self, wait: bool = True) -> tuple[bytes, int] | None:
        """The next frame and its kernel arrival time in ns (needs :meth:`filter_as_tap`).

        ``wait`` False: only a frame already queued, None at once if there is none.
        """
        try:
            data, ancillary, _, _ = self.sock.recvmsg(MAX_FRAME, 64, 0 if wait else _DONTWAIT)
        except (BlockingIOError, InterruptedError):
            return None
        for level, kind, value in ancillary:
            if level == socket.SOL_SOCKET and kind == SO_TIMESTAMPNS:
                seconds, nanos = _TIMESPEC.unpack(value[: _TIMESPEC.size])
                return data, seconds * 1_000_000_000 + nanos
        # No kernel stamp (it was not switched on): the arrival time is now.
        return data, time.time_ns()

    def close(self) -> None:
        self.sock.close()
