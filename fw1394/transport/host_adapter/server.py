"""A bus's host adapter: the one host member every program on this machine shares.

On a real 1394 bus the PC is one node (its OHCI link) however many programs
use it; a program opening ``/dev/fw*`` causes no bus reset. The adapter is
that node for a virtual bus: ``fw1394 bus up`` starts it as
``python -m fw1394.transport.host_adapter.server``, it joins the bus once as a
:class:`~fw1394.transport.bus_host.BusHost`, and listens on the Unix socket
``adapter.sock`` (mode 0600) in the bus's runtime directory. Clients
(``fw1394 read``, the host library's ``AdapterPort``, scripts) send requests
in the framing of :mod:`fw1394.transport.host_adapter.protocol`; the adapter runs
them on its own transaction labels, so several clients with several
transactions each share the 64 labels of one node, and answers each when its
transaction ends. Clients come and go without the bus noticing.

``send`` puts a client's packet on the bus as it is, malformed or not (the
adapter's frame header names the adapter as sender, so answers come back to
it), and reports the ack and the response that came back for it.

A connection starts with ``hello`` (the protocol version), and every request
runs only in the bus generation it was addressed in: one from an earlier
generation is answered ``stale`` and never sent, since its physical ID may
belong to another node now (``docs/host-adapter.md``).
"""

from __future__ import annotations

import argparse
import contextlib
import math
import os
import select
import signal
import socket
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import FrameType

from fw1394.engine import LockCompleted, ReadCompleted, TransactionFailed
from fw1394.packets.accessors import TCODE, TLABEL
from fw1394.packets.ack import ack_code
from fw1394.packets.enums import AckCode
from fw1394.packets.tcodes import RESPONSE_TCODES
from fw1394.transport.bus_host import BusError, BusHost, StaleGenerationError
from fw1394.transport.copies import HostLink
from fw1394.transport.host_adapter.express import Express
from fw1394.transport.host_adapter.protocol import (
    CHOSEN,
    NONE,
    STALE,
    VERSIONS,
    FrameBuffer,
    Op,
    ProtocolError,
    Reply,
    Request,
    Status,
    Transfer,
    choose_version,
    ok_reply,
    one_transfer,
    parse_request,
)
from fw1394.transport.host_adapter.services import NodeServices, is_request
from fw1394.transport.link import ACK, ACK_BYTES, ACK_SIZE, ASYNC_PACKET
from fw1394.transport.media.idle import PollPermit
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.sansio.wire import ACK_PAYLOAD, NO_PHY, FrameHeader, pack_table
from fw1394.transport.supervision.observe import BusView, watch
from fw1394.transport.supervision.procs import die_with_parent
from fw1394.transport.supervision.runtime import adapter_socket, prepare

ADAPTER_MODULE = "fw1394.transport.host_adapter.server"
PID_FILE = "adapter.pid"
#: The adapter wakes at least this often (timers of the bus and of raw sends).
_LONGEST_SLEEP = 0.05
#: A client that does not take its replies within this long is dropped.
_SEND_TIMEOUT = 2.0
_clock = time.monotonic


@dataclass
class RawSend:
    """A packet a client put on the bus, and what came back for it so far."""

    client: Client
    request: int
    destination: int
    sequence: int
    #: The packet's tlabel and tcode, when it is long enough to have them.
    tlabel: int | None
    deadline: float
    expects_response: bool
    ack: int | None = None
    response: bytes = b""

    @property
    def done(self) -> bool:
        if self.response:
            return True
        if self.ack is None:
            return False
        return not (self.expects_response and self.ack == AckCode.ack_pending)


@dataclass(eq=False)
class Client:
    sock: socket.socket
    frames: FrameBuffer = field(default_factory=FrameBuffer)
    #: The protocol version agreed in ``hello``; None before it.
    version: int | None = None

    def __post_init__(self) -> None:
        #: The socket's descriptor, kept: a closed socket forgets it.
        self.fd = self.sock.fileno()


#: Who asked for a transaction: the client, and its request number.
Asked = tuple[Client, int]


class AdapterLink(HostLink):
    """The host's link, which first hands raw sends the answers meant for them.

    The acks it owes for the responses it takes wait in :attr:`acks` until the
    adapter has sent its clients the replies those responses end
    (:meth:`send_acks`): no node waits for the ack of a response, while the
    program waiting for the reply is the next step of the bus's work. They still
    go out before any request read after them.
    """

    def __init__(self, host: BusHost) -> None:
        self._send_frame = host.station.send
        super().__init__(host.requester, self._send_or_hold, host.station)
        self.raw: dict[int, RawSend] = {}  # by the frame sequence number it went out in
        #: Requests other nodes address to the adapter's own node go here.
        self.on_request: Callable[[FrameHeader, bytes], None] | None = None
        #: Acks of responses taken, to go out after the replies: (destination, payload).
        self.acks: list[tuple[int, bytes]] = []

    def _send_or_hold(self, kind: int, destination: int, payload: bytes) -> int | None:
        if kind == ACK:
            self.acks.append((destination, payload))
            return None
        return self._send_frame(kind, destination, payload)

    def send_acks(self) -> None:
        acks, self.acks = self.acks, []
        send = self._send_frame
        for destination, payload in acks:
            send(ACK, destination, payload)

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if self.raw and self._for_raw(header, payload):
            return
        if header.kind == ASYNC_PACKET and self.on_request is not None and is_request(payload):
            self.on_request(header, payload)
            return
        super().take(header, payload, now)

    def _for_raw(self, header: FrameHeader, payload: bytes) -> bool:
        if header.kind == ACK and len(payload) >= ACK_SIZE:
            byte, _, _, sequence = ACK_PAYLOAD.unpack_from(payload)
            pending = self.raw.get(sequence)
            if pending is None or pending.destination != header.sender_phy:
                return False
            pending.ack = ack_code(byte)
            pending.response = payload[ACK_SIZE:]
            return True
        if header.kind != ASYNC_PACKET or len(payload) < 4:
            return False
        if TCODE.of_bytes(payload) not in RESPONSE_TCODES:
            return False
        tlabel = TLABEL.of_bytes(payload)
        for pending in self.raw.values():
            matches = pending.tlabel is None or pending.tlabel == tlabel
            if pending.destination == header.sender_phy and not pending.response and matches:
                pending.response = payload
                # A link acks every response it takes.
                ack = ACK_PAYLOAD.pack(ACK_BYTES[AckCode.ack_complete], tlabel, 0, header.sequence)
                self.send(ACK, header.sender_phy, ack)
                return True
        return False


class AdapterHost(BusHost):
    """A :class:`BusHost` served from an event loop rather than from blocking calls."""

    def __init__(self, config: BusConfig, **kw: object) -> None:
        super().__init__(config, **kw)  # type: ignore[arg-type]
        self.link = self.adapter_link = link = AdapterLink(self)
        #: Raw sends waiting for their answers, by frame sequence number.
        self.raw = link.raw
        self.link.on_reset = self._on_reset
        self.link.on_progress = self._collect
        self._flush_requests = self.link.flush
        #: Told of each express flight handed to the engine: its transaction id, its owner.
        self.on_adopt: Callable[[int, Asked], None] = lambda tid, owner: None
        #: Told of each express flight that ended well: its owner, its data.
        self.on_answer: Callable[[Asked, bytes], None] = lambda owner, data: None
        #: Frames may wait on the bus socket (:meth:`take_frames` stopped at an answer):
        #: no request is read until they are taken, since one may be a bus reset. A
        #: poll that finds the socket empty clears it.
        self.behind = False
        self.express: Express[Asked] = Express(
            self,
            link,
            lambda tid, owner: self.on_adopt(tid, owner),
            lambda owner, data: self.on_answer(owner, data),
        )

    def next_wake(self) -> float:
        due, other = self.link.due, self.station.wake_by
        if other < due:
            due = other
        deadline = self.requester.next_deadline()
        if deadline is not None:
            # The engine's timers are looked at once a millisecond (keep_timers).
            due = min(due, max(deadline, self._timers_due))
        if self.raw:
            due = min(due, *(pending.deadline for pending in self.raw.values()))
        flight = self.express.flight
        if flight is not None and flight.deadline < due:
            due = flight.deadline
        return due

    def take_frames(self, now: float) -> bool:
        """Take every frame queued on the bus socket (never waits); whether any of
        them was a data frame (bus management expects no answer)."""
        link, station, express = self.link, self.station, self.express
        taken = self.behind = False
        for header, payload in station.catch_up():
            taken = True
            if express.flight is None or not express.take(header, payload, now):
                link.receive(header, payload, now)
            elif express.flight is None:
                # The flight's answer, its reply sent: frames behind it wait for the
                # next turn (the socket stays readable), not a receive that finds none.
                self.behind = True
                break
        flight = express.flight
        if flight is not None and flight.generation != station.generation:
            express.adopt()  # the engine fails it with the reset, as its own
        link.apply_changes()
        # An answer frees a label: a request queued for one goes out now.
        self._flush_requests()
        return taken

    def keep_timers(self, now: float) -> None:
        """Run the station's timers and the engine's when they are due."""
        link, station, express = self.link, self.station, self.express
        if express.flight is not None and (
            now >= express.flight.deadline or now >= link.due or now >= station.wake_by
        ):
            # No answer in its ack timeout, or the station's timers may reset the bus:
            # the engine takes over (and its timers are looked at now).
            express.adopt()
            self._timers_due = 0.0
        if now >= link.due or now >= station.wake_by:
            link.service(now)
        self.check_timers(now)
        self._served_at = now
        # Unsolicited responses and stray acks: nobody here asks for them.
        self._other_events.clear()

    def finished(self, tid: int) -> object | None:
        return self._finished.pop(tid, None)

    def start_express(
        self,
        owner: Asked,
        generation: int,
        write: bool,
        quadlet: bool,
        node: int,
        offset: int,
        length: int,
        data: bytes,
    ) -> bool:
        """:meth:`Express.start` pinned to bus ``generation`` (:meth:`addressed_in`
        without its context manager, which costs more than the rest); False when the
        express path does not take it, also when ``generation`` has ended (nothing was
        sent: the general path answers it)."""
        outer, self._addressed_in = self._addressed_in, generation
        try:
            return self.express.start(owner, write, quadlet, node, offset, length, data)
        except StaleGenerationError:
            return False
        finally:
            self._addressed_in = outer

    def send_raw(self, destination: int, packet: bytes) -> int:
        """Put ``packet`` on the bus to physical ID ``destination``; its frame's sequence."""
        self.on_bus()
        return self.station.send(ASYNC_PACKET, destination, packet)


class Adapter:
    """The adapter's event loop: the bus socket, the listening socket, the clients."""

    def __init__(self, host: AdapterHost, path: Path) -> None:
        self.host = host
        self.path = path
        self.listener = _listen(path)
        self.clients: dict[socket.socket, Client] = {}
        self.pending: dict[int, Asked] = {}  # transaction -> client, request
        #: Transactions of clients that left before they ended: their ends are dropped.
        self.orphans: set[int] = set()
        self.stopping = False
        self.services = NodeServices(self)
        host.adapter_link.on_request = self.services.from_bus
        host.on_adopt = self._adopted
        host.on_answer = self._answered
        self._poller = select.epoll()
        self._poller.register(self.listener, select.EPOLLIN)
        self._by_fd: dict[int, Client] = {}
        # How the adapter waits: the bus's idle strategy (fw1394.transport.media.idle),
        # polling for a window after traffic while every runnable task has a core.
        self._window = host.station.idle.window
        self._traffic = -math.inf
        self._permit = PollPermit()
        self._yield: Callable[[], None] = getattr(os, "sched_yield", lambda: None)

    def close(self) -> None:
        for sock in self.clients:
            sock.close()
        self.listener.close()
        self._poller.close()
        with contextlib.suppress(FileNotFoundError):
            self.path.unlink()
        self.host.close()

    def run(self) -> None:
        host = self.host
        medium, link, services = host.station.medium, host.adapter_link, self.services
        poller = self._poller
        listener = self.listener.fileno()
        waiting = self._by_fd.get
        bus = medium.sock
        bus_fd = bus.fileno()
        poller.register(bus, select.EPOLLIN)
        while not self.stopping:
            if medium.sock is not bus:  # a medium that moved to a new socket
                with contextlib.suppress(OSError):
                    poller.unregister(bus)
                bus = medium.sock
                bus_fd = bus.fileno()
                poller.register(bus, select.EPOLLIN)
            events = self._wait()
            now = _clock()
            # The bus first: a reset it reports decides which requests read below are stale.
            bus_readable = not events
            for fd, _ in events:
                if fd == bus_fd:
                    bus_readable = True
                    break
            if not bus_readable:
                host.behind = False  # nothing waited on the bus socket as we polled
            elif host.take_frames(now):
                self._traffic = now
            services.after_serve()
            if host._finished or host.raw:
                self._answer_finished()
            # The programs have their replies; now the acks of the responses they ended.
            if link.acks:
                link.send_acks()
            for fd, _ in () if host.behind else events:
                client = waiting(fd)
                if client is not None:
                    self._read(client)
                    self._traffic = now
                elif fd == listener:
                    self._accept()
            if host._finished or host.raw or link.acks:
                self._answer_finished()
                link.send_acks()
            host.keep_timers(now)

    def _wait(self) -> list[tuple[int, int]]:
        """What is readable: at once while there was traffic within the idle window
        (polled, yielding the CPU between polls), else after blocking until some
        socket is readable or a timer is due."""
        poll, clock = self._poller.poll, _clock
        now = clock()
        if self._window == math.inf:  # spin: always polls, and wakes for the timers
            until = min(self.host.next_wake(), now + _LONGEST_SLEEP)
        else:
            until = self._permit.until(now, self._traffic + self._window)
        if now < until:
            pause = self._yield
            while True:
                events = poll(0)
                if events or clock() >= until:
                    break
                pause()
            if events:
                return events
        wait = min(_LONGEST_SLEEP, max(0.0, self.host.next_wake() - clock()))
        try:
            return poll(wait)
        except InterruptedError:
            return []

    # -- clients ----------------------------------------------------------------------
    def _accept(self) -> None:
        try:
            sock, _ = self.listener.accept()
        except OSError:
            return
        sock.setblocking(False)
        client = Client(sock)
        self.clients[sock] = client
        self._by_fd[sock.fileno()] = client
        self._poller.register(sock, select.EPOLLIN)

    def _drop(self, client: Client) -> None:
        if self.clients.pop(client.sock, None) is None:
            return
        flight = self.host.express.flight
        if flight is not None and flight.owner[0] is client:
            self.host.express.adopt()  # and so orphaned below
        self._by_fd.pop(client.fd, None)
        client.sock.close()  # which takes it out of the poller too
        self.services.dropped(client)
        self.orphans |= {t for t, p in self.pending.items() if p[0] is client}
        self.pending = {t: p for t, p in self.pending.items() if p[0] is not client}
        raw = self.host.raw
        for sequence in [s for s, r in raw.items() if r.client is client]:
            del raw[sequence]

    def _read(self, client: Client) -> None:
        try:
            data = client.sock.recv(1 << 16)
        except (BlockingIOError, InterruptedError):
            return
        except OSError:
            data = b""
        if not data:
            self._drop(client)
            return
        if client.frames.empty and client.version is not None:
            transfer = one_transfer(data)
            if transfer is not None and self._express(client, transfer):
                return
        try:
            bodies = client.frames.feed(data)
            for body in bodies:
                request = parse_request(body)
                if client.version is None:
                    if not self._greet(client, request):
                        return
                    continue
                try:
                    self._handle(client, request)
                except Exception as error:  # one client's request never ends the bus's adapter
                    detail = f"adapter error: {type(error).__name__}: {error}"
                    self._reply(client, Reply(request.request, Status.refused, detail=detail))
        except ProtocolError as error:
            self._reply(client, Reply(0, Status.refused, detail=str(error)))
            self._drop(client)

    def _express(self, client: Client, transfer: Transfer) -> bool:
        """Start the read or write ``transfer`` on the express path; False: nothing
        was done, the general way (:meth:`_handle`) is to take it."""
        number, op, node, generation, offset, length, quadlet, data = transfer
        host = self.host
        if host.express.flight is not None or node == host.station.membership.phy_id:
            return False  # the engine's, or the adapter's own node's (services)
        owner = (client, number)
        try:
            return host.start_express(
                owner, generation, op == Op.write, bool(quadlet), node, offset, length, data
            )
        except Exception as error:  # one client's request never ends the bus's adapter
            detail = f"adapter error: {type(error).__name__}: {error}"
            self._reply(client, Reply(number, Status.refused, detail=detail))
            return True

    def _answered(self, owner: Asked, data: bytes) -> None:
        """Reply to the owner of an express flight that ended well."""
        membership = self.host.station.membership
        phy = membership.phy_id
        client, number = owner
        phy = NO_PHY if phy is None else phy
        self._deliver(client, ok_reply(number, membership.generation, phy, data))

    def _reply(self, client: Client, reply: Reply) -> None:
        host = self.host
        phy = host.phy_id
        self._deliver(client, reply.pack(host.generation, NO_PHY if phy is None else phy))

    def _deliver(self, client: Client, message: bytes) -> None:
        sock = client.sock
        try:
            sent = sock.send(message)
        except (BlockingIOError, InterruptedError):
            sent = 0
        except OSError:
            self._drop(client)
            return
        if sent == len(message):
            return
        # The client's socket is full: it has _SEND_TIMEOUT to take the rest.
        try:
            sock.settimeout(_SEND_TIMEOUT)
            sock.sendall(message[sent:])
            sock.setblocking(False)
        except OSError:
            self._drop(client)

    def _greet(self, client: Client, request: Request) -> bool:
        """The first request of a connection: ``hello``; False if the client was dropped."""
        spoken = ", ".join(str(v) for v in sorted(VERSIONS))
        version = choose_version(request) if request.op is Op.hello else None
        if version is None:
            if request.op is Op.hello:
                detail = f"no protocol version in common: this adapter speaks {spoken}"
            else:
                detail = f"the first request must be hello (this adapter speaks version {spoken})"
            self._reply(client, Reply(request.request, Status.refused, detail=detail))
            self._drop(client)
            return False
        client.version = version
        chosen = CHOSEN.build({"version": version})
        self._reply(client, Reply(request.request, Status.ok, data=chosen))
        return True

    # -- requests ---------------------------------------------------------------------
    def _handle(self, client: Client, request: Request) -> None:
        host = self.host
        op = request.op
        express = host.express
        if express.flight is not None and op is not Op.read and op is not Op.write:
            express.adopt()  # whatever this request does, the engine knows of the flight
        try:
            if op is Op.info:
                host.wait_ready()
                table = pack_table(host.members)
                self._reply(client, Reply(request.request, Status.ok, data=table))
                return
            if op is Op.hello:
                raise ValueError("hello comes once, first")
            # Pinned: a request whose generation has ended is never sent (its
            # physical ID may be another node's now).
            with host.addressed_in(request.generation):
                if op is Op.send:
                    self._send(client, request)
                    return
                if self.services.handle(client, request):
                    return
                if (op is Op.read or op is Op.write) and express.start(
                    (client, request.request),
                    op is Op.write,
                    request.quadlet,
                    request.node,
                    request.offset,
                    request.length,
                    request.data,
                ):
                    return
                express.adopt()
                tid = self._start(request)
        except StaleGenerationError as error:
            addressed = STALE.pack(request.generation)
            stale = Reply(
                request.request, Status.stale, detail=error.failure.detail, data=addressed
            )
            self._reply(client, stale)
            return
        except (ValueError, BusError) as error:
            self._reply(client, Reply(request.request, Status.refused, detail=str(error)))
            return
        self.pending[tid] = (client, request.request)

    def _start(self, request: Request) -> int:
        host, node, offset = self.host, request.node, request.offset
        if request.op is Op.read:
            if request.quadlet:
                return host.start_read_quadlet(node, offset)
            return host.start_read_block(node, offset, request.length)
        if request.op is Op.write:
            if request.quadlet:
                if len(request.data) != 4:
                    raise ValueError("a quadlet write carries 4 bytes")
                return host.start_write_quadlet(node, offset, int.from_bytes(request.data, "big"))
            return host.start_write_block(node, offset, request.data)
        if request.op is Op.lock:
            return host.start_lock(
                node, offset, request.extended_tcode, request.argument, request.data
            )
        raise ValueError(f"unknown operation {request.op}")

    def _send(self, client: Client, request: Request) -> None:
        packet = request.data
        if not packet:
            raise ValueError("no packet to send")
        tcode = TCODE.of_bytes(packet) if len(packet) >= 4 else None
        sequence = self.host.send_raw(request.node, packet)
        self.host.raw[sequence] = RawSend(
            client,
            request.request,
            request.node,
            sequence,
            TLABEL.of_bytes(packet) if len(packet) >= 4 else None,
            time.monotonic() + max(0.0, min(request.wait, 10.0)),
            expects_response=tcode is not None and tcode not in RESPONSE_TCODES,
        )

    def _adopted(self, tid: int, owner: Asked) -> None:
        self.pending[tid] = owner

    def _answer_finished(self) -> None:
        host = self.host
        for tid in [t for t in self.orphans if t in host._finished]:
            host.finished(tid)
            self.orphans.discard(tid)
        for tid in [t for t in self.pending if t in host._finished]:
            # A reply that finds its client gone drops the client's other requests.
            asked = self.pending.pop(tid, None)
            if asked is None:
                continue
            self._reply(asked[0], _reply_of(asked[1], host.finished(tid)))
        raw = host.raw
        if raw:
            now = time.monotonic()
            for sequence in [s for s, r in raw.items() if r.done or now >= r.deadline]:
                pending = raw.pop(sequence, None)
                if pending is None:
                    continue
                ack = NONE if pending.ack is None else pending.ack
                reply = Reply(pending.request, Status.ok, ack=ack, data=pending.response)
                self._reply(pending.client, reply)


def _reply_of(request: int, event: object) -> Reply:
    if isinstance(event, ReadCompleted):
        return Reply(request, Status.ok, data=event.data)
    if isinstance(event, LockCompleted):
        return Reply(request, Status.ok, data=event.old_value)
    if isinstance(event, TransactionFailed):
        rcode = NONE if event.rcode is None else event.rcode
        return Reply(
            request,
            Status.failed,
            rcode=rcode,
            outcome_unknown=event.outcome_unknown,
            reason=str(event.reason),
            detail=event.detail,
        )
    return Reply(request, Status.ok)


def _listen(path: Path) -> socket.socket:
    """A listening socket at ``path`` only this user may open (like a 0600 device node)."""
    if path.exists():
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(str(path))
        except OSError:
            path.unlink()  # left by an adapter that died
        else:
            raise OSError(f"an adapter already listens on {path}")
        finally:
            probe.close()
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    old_mask = os.umask(0o177)
    try:
        listener.bind(str(path))
    finally:
        os.umask(old_mask)
    path.chmod(0o600)
    listener.listen(64)
    return listener


def wait_adapter(config: BusConfig, directory: Path, timeout: float) -> BusView | None:
    """The bus view once the adapter of ``directory`` listens and is a member; None if not."""
    limit = time.monotonic() + timeout
    path = adapter_socket(directory)
    while not path.exists():
        if time.monotonic() > limit:
            return None
        time.sleep(0.02)
    pid = adapter_pid(directory)
    if pid is None:
        return None
    remaining = max(0.1, limit - time.monotonic())
    return watch(config, remaining, lambda view: any(m.pid == pid for m in view.members))


def adapter_pid(directory: Path) -> int | None:
    """The pid of the adapter of bus directory ``directory``, if one runs."""
    try:
        return int((directory / PID_FILE).read_text())
    except (OSError, ValueError):
        return None


def parse_args(argv: list[str]) -> argparse.Namespace:
    parser = argparse.ArgumentParser(
        prog="python -m fw1394.transport.host_adapter.server",
        description="The host adapter of a virtual bus (started by `fw1394 bus up`).",
        allow_abbrev=False,
    )
    parser.add_argument("--name", required=True)
    parser.add_argument("--interface", default="127.0.0.1")
    parser.add_argument("--ttl", type=int, default=0)
    parser.add_argument("--heartbeat", type=float, default=None)
    parser.add_argument("--lease", type=float, default=None)
    parser.add_argument(
        "--ack-timeout", type=float, default=1.0, help="seconds a request waits for its ack"
    )
    parser.add_argument(
        "--split-timeout", type=float, default=1.0, help="seconds a request waits for its response"
    )
    parser.add_argument("--root", type=Path, default=None)
    parser.add_argument("--parent-pid", type=int, default=None)
    # A supervisor hands on its node options; the adapter takes only the bus's.
    args, _ = parser.parse_known_args(argv)
    return args


def main(argv: list[str]) -> int:
    args = parse_args(argv)
    if args.parent_pid is not None:
        die_with_parent(args.parent_pid)
    config = BusConfig(args.name, interface=args.interface, ttl=args.ttl)
    timing = Timing()
    if args.heartbeat is not None:
        timing = replace(timing, heartbeat=args.heartbeat)
    if args.lease is not None:
        timing = replace(timing, lease=args.lease)
    directory = prepare(args.name, args.root)
    host = AdapterHost(
        config, timing=timing, ack_timeout=args.ack_timeout, split_timeout=args.split_timeout
    )
    try:
        host.wait_ready(timeout=math.inf if args.parent_pid else None)
        # The pid first: whoever sees the socket can tell the adapter's member by it.
        (directory / PID_FILE).write_text(str(os.getpid()))
        adapter = Adapter(host, adapter_socket(directory))
    except (BusError, OSError) as error:
        host.close()
        print(f"fw1394 adapter: {error}", file=sys.stderr)
        return 1

    def stop(signum: int, frame: FrameType | None) -> None:
        adapter.stopping = True

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    try:
        adapter.run()
    finally:
        adapter.close()
        with contextlib.suppress(FileNotFoundError):
            (directory / PID_FILE).unlink()
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
