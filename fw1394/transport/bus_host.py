"""The host side of the bus: a station driving the engine's :class:`Requester`.

:class:`BusHost` is the low-level interface: start transactions (several may
be outstanding), then :meth:`BusHost.wait` for their events or
:meth:`BusHost.poll` the bus. :class:`fw1394.host.bus_port.BusPort` puts the
blocking :class:`~fw1394.host.port.Port` calls on top.

A host is a bus member like any node (a contender, so it gets the highest
physical ID and is root). It runs its timers only while inside one of its
calls, so a host left idle for longer than a lease is dropped from the bus.
Before its next transaction it catches up: it takes in what the bus said
meanwhile and, if it was away long enough to be dropped, joins again (a bus
reset) and waits for the new self-ID phase, so the transaction itself
never meets a stale generation.
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Self

from fw1394 import errors
from fw1394.engine import Event, FailureReason, Requester, TransactionEvent, TransactionFailed
from fw1394.engine.faults import FaultConfig
from fw1394.errors import BusUnreachable
from fw1394.packets import AckCode, BlockReadResponse, RCode, name_of
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import BROADCAST_ID, resolve
from fw1394.packets.nodeid import LOCAL_BUS as LOCAL_BUS  # the bus hosts address, re-exported
from fw1394.transport.copies import HostLink
from fw1394.transport.link import ACK_SIZE, BusRefusedError
from fw1394.transport.media.idle import IdleStrategy
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import BusReset, Timing
from fw1394.transport.sansio.wire import HEADER_SIZE, MAX_UDP_PAYLOAD, MemberInfo
from fw1394.transport.station import Station

#: A transaction the engine has not ended this long after its own timeouts is a bug;
#: the guard turns it into an error instead of a hang.
_GUARD_SLACK = 5.0
_TIMER_GRANULARITY = 0.001
#: Header, header CRC and data CRC of a block packet: what a block adds to its data.
_BLOCK_OVERHEAD = len(encode_packet(BlockReadResponse(destination_id=0, tlabel=0, source_id=0)))
#: The longest block whose read response still fits one datagram behind an ack (a
#: concatenated response), and the longest block write request that fits one.
MAX_BLOCK_READ = (MAX_UDP_PAYLOAD - HEADER_SIZE - ACK_SIZE - _BLOCK_OVERHEAD) & ~3
MAX_BLOCK_WRITE = (MAX_UDP_PAYLOAD - HEADER_SIZE - _BLOCK_OVERHEAD) & ~3


class BusError(BusUnreachable):
    """The host could not get onto the bus (no answer, or the bus is full)."""


class EngineTransactionError(errors.TransactionError, RuntimeError):
    """A :class:`fw1394.TransactionError` made of the engine's ``TransactionFailed`` event.

    ``reason`` is the engine's name for why the transaction failed.

    ``ack`` holds the ack code of an ``ack_*_error`` failure and ``rcode`` the
    response code of an ``rcode_error``. Like ``OSError`` with an errno, the
    constructor returns the more specific :class:`TransactionTimeout` when
    nothing answered (no ack, or no response in time), so ``except
    fw1394.Timeout`` catches those wherever they come from.
    """

    def __new__(cls, *args: object, **kwargs: object) -> EngineTransactionError:
        # Subclasses keep their own constructor arguments; only the base picks.
        failure = args[0] if args else kwargs.get("failure")
        if (
            cls is EngineTransactionError
            and isinstance(failure, TransactionFailed)
            and failure.reason in _UNANSWERED
        ):
            cls = TransactionTimeout
        return super().__new__(cls, *args, **kwargs)

    def __init__(self, failure: TransactionFailed) -> None:
        self.failure = failure
        self.reason = failure.reason
        text = str(failure.reason)
        if failure.rcode is not None:
            text += f" ({name_of(RCode, failure.rcode)})"
        if failure.detail and failure.detail != text:
            text += f": {failure.detail}"
        ack = AckCode[failure.reason.value] if failure.reason.value in AckCode.__members__ else None
        super().__init__(text, ack=ack, rcode=failure.rcode)


class TransactionTimeout(EngineTransactionError, errors.Timeout):
    """A transaction no node answered: no ack, or no response before the split timeout."""


#: The name the ports raise and catch it by.
TransactionError = EngineTransactionError


_UNANSWERED = frozenset({FailureReason.no_ack, FailureReason.response_timeout})


class StaleGenerationError(TransactionError):
    """A request addressed in a bus generation that has ended: it was never sent.

    Physical IDs are renumbered at every bus reset, so the node a request named
    may be another node now (Linux's firewire-cdev fails such a request with
    ``EAGAIN``). Its reason is ``bus_reset``; ``addressed`` and ``current`` are
    the two generations.
    """

    def __new__(cls, addressed: int, current: int) -> StaleGenerationError:
        # The engine error's constructor takes a failure event; this one takes generations.
        return Exception.__new__(cls)

    def __init__(self, addressed: int, current: int) -> None:
        self.addressed, self.current = addressed, current
        detail = f"addressed in generation {addressed}, the bus is in {current}: not sent"
        super().__init__(TransactionFailed(0, FailureReason.bus_reset, detail=detail))


class BusHost:
    """A host member of bus ``config.name``."""

    def __init__(
        self,
        config: BusConfig | None = None,
        *,
        ack_timeout: float = 0.5,
        split_timeout: float = 1.0,
        max_busy_retries: int = 3,
        join_timeout: float = 10.0,
        timing: Timing | None = None,
        faults: FaultConfig | None = None,
        poll_interval: float = 0.005,
        idle: IdleStrategy | None = None,
    ) -> None:
        self.config = config or BusConfig()
        self.join_timeout = join_timeout
        self.station = Station(
            self.config,
            contender=True,
            host=True,
            timing=timing,
            faults=faults,
            poll_interval=poll_interval,
            idle=idle,
        )
        self.requester = Requester(
            node_id=BROADCAST_ID,  # no physical ID before the first self-ID phase
            split_timeout=split_timeout,
            ack_timeout=ack_timeout,
            max_busy_retries=max_busy_retries,
            # Loopback multicast copies no frame unless this host is told to: only
            # then hold labels after an answer for a copy to pass (docs/engine.md).
            duplicate_window=None if faults is not None and faults.duplicate else 0.0,
        )
        # Every answer taken once: a copy must not complete a transaction that
        # reuses its label (fw1394.transport.copies).
        self.link: HostLink = HostLink(self.requester, self.station.send, self.station)
        self.link.on_reset = self._on_reset
        self.link.on_progress = self._collect
        self._flush_requests = self.link.flush
        self._finished: dict[int, TransactionEvent] = {}
        self._other_events: list[Event] = []
        self._timers_due = 0.0
        #: When the host last served the bus (its timers run only inside its calls).
        self._served_at = time.monotonic()
        self._paused_after = self.station.membership.timing.heartbeat
        self.resets: list[BusReset] = []
        #: The generation requests started now are pinned to (None: the current one).
        self._addressed_in: int | None = None

    # -- context manager ----------------------------------------------------------------
    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self.station.close()

    # -- the bus ------------------------------------------------------------------------
    @property
    def generation(self) -> int:
        return self.station.generation

    @property
    def phy_id(self) -> int | None:
        return self.station.phy_id

    @property
    def members(self) -> tuple[MemberInfo, ...]:
        return self.station.membership.members

    def nodes(self) -> list[tuple[int, MemberInfo]]:
        """(physical ID, member) of every member but this host, after self-ID."""
        self.wait_ready()
        me = self.station.member_id
        return [(phy, m) for phy, m in enumerate(self.members) if m.member_id != me]

    def wait_ready(self, timeout: float | None = None) -> None:
        """Block until this host is on the bus with its self-ID phase complete."""
        self._back_if_away()
        membership = self.station.membership
        if membership.ready:
            return
        seconds = self.join_timeout if timeout is None else timeout
        limit = time.monotonic() + seconds
        while not membership.ready:
            if time.monotonic() > limit:
                raise BusError(
                    f"not on bus {self.config.name!r} after {seconds:.1f} s "
                    f"(role {membership.role}, generation {membership.generation})"
                )
            self._pump()

    def reset(self) -> None:
        """Ask for a bus reset and wait until the next generation is ready."""
        self.wait_ready()
        before = self.generation
        self.station.request_reset()
        limit = time.monotonic() + self.join_timeout
        while self.generation == before or not self.station.membership.ready:
            if time.monotonic() > limit:
                raise BusError("the bus did not reset")
            self._pump()

    # -- transactions (non-blocking starts) ----------------------------------------------
    @contextmanager
    def addressed_in(self, generation: int | None) -> Iterator[None]:
        """Requests started inside are pinned to bus ``generation`` (None: not pinned).

        One whose generation has ended by the time it would go out raises
        :class:`StaleGenerationError` and is not sent: its physical ID may name
        another node now.
        """
        outer, self._addressed_in = self._addressed_in, generation
        try:
            yield
        finally:
            self._addressed_in = outer

    def start_read_quadlet(self, node: int, offset: int) -> int:
        tid = self.requester.read_quadlet(resolve(node), offset, self.on_bus())
        self._flush_requests()
        return tid

    def start_read_block(self, node: int, offset: int, length: int) -> int:
        # A keyed bus's frames end with a trailer: its blocks are that much shorter.
        if length > (limit := MAX_BLOCK_READ - self.station.trailer_size):
            raise ValueError(
                f"a block read of {length} bytes cannot cross the virtual bus: its response "
                f"would not fit one datagram (at most {limit} bytes per read)"
            )
        tid = self.requester.read_block(resolve(node), offset, length, self.on_bus())
        self._flush_requests()
        return tid

    def start_write_quadlet(self, node: int, offset: int, value: int) -> int:
        tid = self.requester.write_quadlet(resolve(node), offset, value, self.on_bus())
        self._flush_requests()
        return tid

    def start_write_block(self, node: int, offset: int, data: bytes) -> int:
        if len(data) > (limit := MAX_BLOCK_WRITE - self.station.trailer_size):
            raise ValueError(
                f"a block write of {len(data)} bytes cannot cross the virtual bus: it would "
                f"not fit one datagram (at most {limit} bytes per write)"
            )
        tid = self.requester.write_block(resolve(node), offset, data, self.on_bus())
        self._flush_requests()
        return tid

    def start_lock(
        self, node: int, offset: int, extended_tcode: int, argument: bytes, data: bytes
    ) -> int:
        now = self.on_bus()
        tid = self.requester.lock(resolve(node), offset, extended_tcode, argument, data, now)
        self._flush_requests()
        return tid

    def wait(self, tid: int) -> TransactionEvent:
        """The event that ended transaction ``tid`` (completed or failed)."""
        finished = self._finished
        requester, pump, clock = self.requester, self._pump, time.monotonic
        guard = clock() + requester.ack_timeout + _GUARD_SLACK
        guard += requester.split_timeout * (1 + requester.max_busy_retries)
        while tid not in finished:
            if clock() > guard:
                return TransactionFailed(tid, FailureReason.response_timeout, detail="no end")
            pump()
        return finished.pop(tid)

    def poll(self, timeout: float) -> list[Event]:
        """Serve the bus for ``timeout`` seconds; events other than transaction ends."""
        self._back_if_away()
        limit = time.monotonic() + timeout
        while time.monotonic() < limit:
            self._pump()
        events, self._other_events = self._other_events, []
        return events

    # -- the loop -----------------------------------------------------------------------
    def on_bus(self) -> float:
        """Make sure this host is on the bus and ready; the time it was sure of it.

        Every request is started right after this: it raises
        :class:`StaleGenerationError` if the request is pinned to a generation
        (:meth:`addressed_in`) the bus has left.
        """
        now = self._back_if_away()
        station = self.station
        if not station.membership.ready:
            self.wait_ready()
            now = time.monotonic()
        if self.requester.generation != station.generation:
            self.link.apply_changes()  # the engine learns of a reset before it sends
        pinned = self._addressed_in
        if pinned is not None and pinned != station.generation:
            raise StaleGenerationError(pinned, station.generation)
        return now

    def _back_if_away(self) -> float:
        """Catch up with the bus if this host has been away from it; now."""
        now = time.monotonic()
        if now - self._served_at > self.station.membership.timing.heartbeat:
            self._come_back(now)
        return now

    def _come_back(self, now: float) -> None:
        # The bus went on without this host: what it said meanwhile comes first, so
        # that a reset that happened is known before anything is sent.
        station, link = self.station, self.link
        away = now - self._served_at
        try:
            for header, payload in station.catch_up():
                link.receive(header, payload, now)
            link.apply_changes()
            timing = station.membership.timing
            if away >= timing.lease - timing.heartbeat:
                # The coordinator has dropped this host, or may be doing so right now:
                # a reset that removes it could otherwise still fail the next
                # transaction. Joining again is one reset, and it is over before any
                # request goes out.
                station.rejoin()
            link.service(now)
        except BusRefusedError as error:
            raise self.refused(error) from None
        self._served_at = now

    def _pump(self) -> None:
        try:
            now = self.link.turn()
        except BusRefusedError as error:
            raise self.refused(error) from None
        self.after_turn(now)

    def after_turn(self, now: float) -> None:
        """What the host does after each turn of its link, which ended at ``now``."""
        if now - self._served_at > self._paused_after:
            # Stopped inside a call: the answers that queued up meanwhile are taken
            # before any engine timer can call them missing.
            self._come_back(now)
        self._served_at = now
        self.check_timers(now)

    def check_timers(self, now: float) -> None:
        """Fire the engine's timers that are due at ``now``."""
        if now >= self._timers_due:
            # Engine timeouts are tens of milliseconds and up: looking at them once a
            # millisecond is precise enough and keeps the heap off the per-packet path.
            self._timers_due = now + _TIMER_GRANULARITY
            requester = self.requester
            due = requester.next_deadline()
            if due is not None and now >= due:
                requester.handle_timer(now)
                self._flush_requests()
                self._collect()

    def refused(self, error: BusRefusedError) -> BusError:
        """The error a blocking call raises when the coordinator refused this host."""
        return BusError(f"bus {self.config.name!r} refused this host: {error}")

    def _on_reset(self, change: BusReset) -> None:
        self.resets.append(change)

    def _collect(self) -> None:
        for event in self.requester.events():
            if isinstance(event, TransactionEvent):
                self._finished[event.transaction] = event
            else:
                self._other_events.append(event)
