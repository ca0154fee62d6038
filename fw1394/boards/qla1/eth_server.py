"""A :class:`~fw1394.boards.qla1.rack.Rack` on loopback UDP sockets, as the real host sees boards.

Sockets (all on 127.0.0.0/8, all with SO_REUSEADDR so the boards of a bus, each
a process, can share the broadcast and multicast addresses). A server refuses
an address another socket already holds, naming who holds it, unless asked to
share it (``share_port``, ``jhu serve --reuse-port``): with two servers on one
unicast address the host's requests would reach only one of them.

* one unicast socket per cabled board, bound to the address the host sends
  that board's requests to (the base address before firmware 9, base + board
  ID from firmware 9 on); replies leave through it, from port 1394 like the
  FPGA's;
* one socket bound to the classful broadcast address of the base
  (127.255.255.255), for the host's broadcasts;
* from firmware 9 on, one socket bound to 224.0.0.100 and joined to it on
  loopback only, for the host's multicasts. Because a real host sends those
  through its routing table, the server refuses firmware >= 9 unless that
  route is on ``lo`` (a network namespace with ``224.0.0.0/4 dev lo``).

Nothing is ever sent to an address outside 127.0.0.0/8.
"""

from __future__ import annotations

import functools
import select
import socket
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from ipaddress import IPv4Address

from fw1394.boards.qla1.ethernet import Reply, datagram
from fw1394.boards.qla1.rack import Rack
from fw1394.packets.eth1394 import MULTICAST_GROUP
from fw1394.transport.eth1394_addresses import (
    LOOPBACK_NETWORK,
    MULTICAST_FIRMWARE,
    AddressRefusedError,
    Endpoint,
    board_address,
    classful_broadcast,
    multicast_route_check,
    require_loopback,
)
from fw1394.transport.udp_ports import refuse_taken_port

MAX_DATAGRAM = 65_535
#: The ``jhu serve`` option that shares a port another server holds.
SHARE_OPTION = "--reuse-port"
LOOPBACK_INTERFACE = "127.0.0.1"
UNSPECIFIED = IPv4Address("0.0.0.0")


class MulticastRefusedError(AddressRefusedError):
    """Firmware >= 9 outside a namespace whose multicast route is on loopback."""


def open_udp(
    address: str, port: int, *, exclusive: bool = False, share_hint: str | None = None
) -> socket.socket:
    """A non-blocking UDP socket bound to ``address:port``, shareable with other processes.

    ``exclusive``: PortInUseError (naming the holder; ``share_hint`` is the option
    that would share instead) if another socket holds the address already.
    """
    if exclusive:
        refuse_taken_port(address, port, share_hint=share_hint)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        sock.bind((address, port))
        sock.setblocking(False)
    except OSError:
        sock.close()
        raise
    return sock


def join_loopback_multicast(sock: socket.socket) -> None:
    """Join 224.0.0.100 on the loopback interface only, and never send multicast off it."""
    group = socket.inet_aton(MULTICAST_GROUP) + socket.inet_aton(LOOPBACK_INTERFACE)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_ADD_MEMBERSHIP, group)
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, socket.inet_aton(LOOPBACK_INTERFACE))
    sock.setsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL, 0)


def check_multicast_allowed(firmware: int) -> None:
    """Refuse a personality that makes a real host multicast off this machine."""
    if firmware < MULTICAST_FIRMWARE:
        return
    problem = multicast_route_check()
    if problem is not None:
        raise MulticastRefusedError(f"firmware {firmware}: {problem}")


def reply_address(sender: tuple[str, int], local: str) -> tuple[str, int]:
    """Where the reply to a request from ``sender`` goes, from a socket bound to ``local``.

    The FPGA answers the request's source address and port, whatever they are
    (EthernetIO.v:420-421,646-650). A real host whose multicast route has no
    source address (``ip route add 224.0.0.0/4 dev lo``, the setup fw1394
    documents) sends its multicast ETH_STATUS read from 0.0.0.0: the
    unspecified address, which only a sender on this very host can use on
    loopback. Linux delivers a datagram sent to 0.0.0.0 to the sending
    socket's own address; so does this, explicitly, and the reply reaches the
    host's socket (bound to the wildcard address) as the firmware's would.
    """
    host, port = sender
    if _is_unspecified(host):
        return local, port
    return sender


# A server answers the same few hosts all the time: each address is parsed once.
@functools.lru_cache(maxsize=256)
def _is_unspecified(host: str) -> bool:
    return IPv4Address(host) == UNSPECIFIED


@functools.lru_cache(maxsize=256)
def _on_loopback(host: str) -> bool:
    return IPv4Address(host) in LOOPBACK_NETWORK


def send_loopback(sock: socket.socket, payload: bytes, address: tuple[str, int]) -> str | None:
    """Send only to 127.0.0.0/8; None when sent, else why not (for :class:`RefusalLog`)."""
    if not _on_loopback(address[0]):
        return f"not a loopback address (fw1394 sends only to {LOOPBACK_NETWORK})"
    try:
        sock.sendto(payload, address)
    except OSError as error:
        return f"send failed: {error.strerror or error}"
    return None


class RefusalLog:
    """Says once per cause that a reply could not be sent, with the first address it hit."""

    def __init__(self, say: Callable[[str], None] | None = None) -> None:
        self._say = say or _to_stderr
        self._causes: set[str] = set()

    def refused(self, address: tuple[str, int], cause: str) -> None:
        if cause in self._causes:
            return
        self._causes.add(cause)
        self._say(
            f"fw1394 jhu: cannot reply to {address[0]}:{address[1]}: {cause} "
            "(further replies refused for this reason are only counted)"
        )


def _to_stderr(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


@dataclass
class ServerStats:
    received: int = 0
    sent: int = 0
    refused: int = 0


@dataclass
class Eth1394Server:
    """Serve ``rack`` at ``endpoint`` (the server IP the host is given, and the port)."""

    rack: Rack
    endpoint: Endpoint = field(default_factory=Endpoint)
    stats: ServerStats = field(default_factory=ServerStats)
    #: Where refused replies are reported (once per cause); default stderr.
    say: Callable[[str], None] | None = None
    #: Bind even where another socket holds the address (both then get datagrams).
    share_port: bool = False

    def __post_init__(self) -> None:
        base = require_loopback(self.endpoint.host)
        check_multicast_allowed(self.rack.firmware)
        self.epoch = time.monotonic()
        self.refusals = RefusalLog(self.say)
        self._unicast: dict[int, socket.socket] = {}
        #: The port a socket's datagrams are for; None: every cabled port.
        self._targets: dict[socket.socket, int | None] = {}
        self._local: dict[int, str] = {}
        #: Every socket, by file descriptor, registered once with the wait (an epoll: the
        #: kernel keeps the set between waits instead of taking all of it every wait).
        self._by_fd: dict[int, socket.socket] = {}
        self._wait = select.epoll()
        self._running = True
        exclusive = not self.share_port
        hint = SHARE_OPTION

        def bind(address: str, port: int) -> socket.socket:
            return open_udp(address, port, exclusive=exclusive, share_hint=hint)

        try:
            port = self.endpoint.port
            for index, port_model in self.rack.ports:
                address = board_address(base, port_model.board.board_id, self.rack.firmware)
                sock = bind(require_loopback(address), port)
                self._unicast[index] = sock
                self._targets[sock] = index
                self._local[index] = sock.getsockname()[0]
            self._targets[bind(classful_broadcast(base), port)] = None
            if self.rack.firmware >= MULTICAST_FIRMWARE:
                group = bind(MULTICAST_GROUP, port)
                self._targets[group] = None
                join_loopback_multicast(group)
        except OSError:
            self.close()
            raise
        for sock in self._targets:
            self._by_fd[sock.fileno()] = sock
            self._wait.register(sock.fileno(), select.EPOLLIN)

    @property
    def addresses(self) -> list[str]:
        """``ip:port`` of every socket (for logs)."""
        return [f"{host}:{port}" for host, port in (s.getsockname() for s in self._targets)]

    def now(self) -> float:
        return time.monotonic() - self.epoch

    def step(self, timeout: float) -> None:
        """Wait at most ``timeout`` s for datagrams; answer them and any timers due.

        The wait blocks in the kernel (epoll) until a datagram comes: no CPU is spent
        while the host is busy, at the price of the scheduler's wake-up on each
        datagram. Each readable socket gives one datagram per step; more waiting
        behind it make the next poll return at once.
        """
        due = self.rack.next_deadline()
        if due is not None:
            timeout = max(0.0, min(timeout, due - self.now()))
        ready = self._wait.poll(timeout)
        replies: list[tuple[int, Reply]] = []
        for fd, _ in ready:
            replies += self._receive(self._by_fd[fd])
        if due is not None:
            # Only a hub read waiting for its round has a deadline; one that starts
            # waiting in this step is due later, and a round that completes answers
            # its waiting reads itself.
            replies += self.rack.poll(self.now())
        processed = self.now()
        for index, reply in replies:
            self.send_reply(index, reply, processed)

    def _receive(self, sock: socket.socket) -> list[tuple[int, Reply]]:
        try:
            payload, sender = sock.recvfrom(MAX_DATAGRAM)
        except (BlockingIOError, InterruptedError):
            return []
        self.stats.received += 1
        now = self.now()
        index = self._targets[sock]
        if index is None:
            return self.rack.receive_everywhere(payload, sender, now)
        return self.rack.receive(index, payload, sender, now)

    def send_reply(self, index: int, reply: Reply, processed: float) -> None:
        """Send ``reply`` through the unicast socket of board ``index`` (stats, refusals)."""
        payload = datagram(reply, processed, self.now())
        sock = self._unicast[index]
        address = reply_address(reply.address, self._local[index])
        cause = send_loopback(sock, payload, address)
        if cause is None:
            self.stats.sent += 1
        else:
            self.stats.refused += 1
            self.refusals.refused(reply.address, cause)

    def serve_forever(self) -> None:
        while self._running:
            self.step(0.1)

    def serve_for(self, seconds: float) -> None:
        limit = time.monotonic() + seconds
        while self._running and time.monotonic() < limit:
            self.step(min(0.05, max(0.0, limit - time.monotonic())))

    def stop(self) -> None:
        self._running = False

    def close(self) -> None:
        self._wait.close()
        for sock in self._targets:
            sock.close()
        self._targets.clear()
        self._unicast.clear()
        self._by_fd.clear()

    def __enter__(self) -> Eth1394Server:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
