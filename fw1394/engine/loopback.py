"""An in-memory bus: one :class:`Requester`, any number of :class:`Responder`\\ s.

:class:`Link` carries packets through the real codec (``encode`` when a packet
is sent, ``decode`` when it arrives) on a fake clock, ``link.now``. It behaves
like a 1394 bus: the addressed node's ack reaches the requester the moment the
request arrives (or ``None`` when no node acked: the transport saw the ack gap
pass), a concatenated response follows its ack with nothing in between, a split
response is a packet of its own that arrives ``split_delay`` later, and a bus
reset destroys everything in flight.

The fault model of a bus member (:class:`~fw1394.engine.faults.FaultConfig`,
through the same :class:`~fw1394.engine.faults.FaultInjector`), driven by
``random.Random(seed)``, loses, duplicates and delays packets; here it also
reorders and corrupts them and loses acks. Everything that crosses the
link is kept, in arrival order, as :class:`Exchange` records in ``link.trace``.

Typical use::

    link = Link(Requester(node_id=0xFFC1), [Responder(0xFFC0, MemorySpace(), THESIS_FPGA)])
    tid = link.requester.read_quadlet(0xFFC0, 0, link.now)
    link.run()                       # until nothing is in flight and no timer is set
    link.requester.events()          # [ReadCompleted(transaction=tid, data=...)]
    link.wire()                      # [("request", ...), ("ack", 2), ("response", ...), ...]
"""

from __future__ import annotations

import heapq
import random
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import NamedTuple

from fw1394.engine.faults import FaultConfig, FaultInjector
from fw1394.engine.requester import Requester
from fw1394.engine.responder import Responder, decode_received
from fw1394.packets import (
    AsyncPacket,
    BlockWriteRequest,
    QuadletWriteRequest,
    RoutedPacket,
)
from fw1394.packets.fast import decode_sound, encode_packet
from fw1394.packets.nodeid import BROADCAST_ID, is_broadcast

_WRITES = (QuadletWriteRequest, BlockWriteRequest)


@dataclass(frozen=True, slots=True)
class Exchange:
    """One thing on the wire, as the trace keeps it."""

    time: float
    #: "request", "response", "ack", "no_ack" or "bus_reset".
    kind: str
    source: int
    destination: int
    #: The request or response as it was sent (before encoding).
    packet: AsyncPacket | None = None
    ack: int | None = None
    concatenated: bool = False
    #: What the fault model did: "dropped", "corrupted", "tampered", "delayed",
    #: "reordered", "duplicate", "discarded" (the requester's link refused it as
    #: damaged) or "lost" (an ack the requester never heard).
    faults: tuple[str, ...] = ()
    #: The wire bytes of a corrupted or tampered packet.
    raw: bytes = field(default=b"", repr=False)


class _Delivery(NamedTuple):
    raw: bytes
    packet: RoutedPacket
    to_requester: bool
    concatenated: bool
    faults: tuple[str, ...]


class Link:
    """Wires ``requester`` to ``responders`` in memory; see the module docstring."""

    def __init__(
        self,
        requester: Requester,
        responders: Iterable[Responder] = (),
        *,
        faults: FaultConfig | None = None,
        seed: int = 0,
        split_delay: float = 0.0,
        report_missing_acks: bool = True,
        start: float = 0.0,
        keep_trace: bool = True,
        tamper: Callable[[RoutedPacket, bytes], bytes] | None = None,
    ) -> None:
        self.requester = requester
        self.responders = list(responders)
        self.faults = faults or FaultConfig()
        self.random = random.Random(seed)
        self._injector = FaultInjector(self.faults, self.random)
        #: How long after its ack a split response arrives.
        self.split_delay = split_delay
        #: Tell the requester at once when no node acked (else its ack timeout does).
        self.report_missing_acks = report_missing_acks
        self.now = start
        self.keep_trace = keep_trace
        #: Called with every packet sent and its wire bytes; returns the bytes to
        #: deliver instead (deterministic damage for tests and fuzzing).
        self.tamper = tamper
        self.trace: list[Exchange] = []
        self._in_flight: list[tuple[float, int, _Delivery]] = []
        self._sequence = 0

    # -- driving -----------------------------------------------------------------------
    def run(self, until: float | None = None) -> None:
        """Deliver packets and fire the requester's timers in time order.

        Stops at ``until`` (the clock is then set to it), or when nothing is in
        flight and no timer is set if ``until`` is ``None``.
        """
        requester = self.requester
        while True:
            for packet in requester.packets_to_send():
                assert isinstance(packet, RoutedPacket)
                self._send(packet, self.now, to_requester=False)
            arrival = self._in_flight[0][0] if self._in_flight else None
            deadline = requester.next_deadline()
            if arrival is None and deadline is None:
                break
            if arrival is not None and (deadline is None or arrival <= deadline):
                if until is not None and arrival > until:
                    break
                self.now = max(self.now, arrival)
                self._deliver(heapq.heappop(self._in_flight)[2])
            else:
                assert deadline is not None
                if until is not None and deadline > until:
                    break
                self.now = max(self.now, deadline)
                requester.handle_timer(self.now)
        if until is not None and until > self.now:
            self.now = until

    def advance(self, seconds: float) -> None:
        """Run for ``seconds`` of fake time."""
        self.run(self.now + seconds)

    def bus_reset(self, generation: int) -> None:
        """A bus reset: packets in flight are lost, every node enters ``generation``."""
        self._in_flight.clear()
        self.requester.bus_reset(generation=generation)
        for responder in self.responders:
            responder.bus_reset(node_id=responder.node_id, generation=generation)
        self._record(Exchange(self.now, "bus_reset", BROADCAST_ID, BROADCAST_ID))

    @property
    def in_flight(self) -> int:
        """Packets sent and not yet arrived."""
        return len(self._in_flight)

    def wire(self) -> list[tuple[str, AsyncPacket | int | None]]:
        """The trace in short: (kind, packet or ack code) per exchange."""
        return [(e.kind, e.packet if e.packet is not None else e.ack) for e in self.trace]

    # -- sending -----------------------------------------------------------------------
    def _send(
        self, packet: RoutedPacket, now: float, *, to_requester: bool, concatenated: bool = False
    ) -> None:
        faults, chance = self.faults, self.random.random
        times = self._injector.send_times(now)
        if not times:
            self._record_packet(now, packet, to_requester, concatenated, ("dropped",))
            return
        raw = encode_packet(packet)
        marks: tuple[str, ...] = ()
        if self.tamper is not None:
            tampered = self.tamper(packet, raw)
            if tampered != raw:
                raw, marks = tampered, ("tampered",)
        if faults.corrupt and chance() < faults.corrupt:
            raw = self._flip_one_bit(raw)
            marks += ("corrupted",)
        when = now
        if not concatenated:
            if to_requester:
                when += self.split_delay
            if times[0] > now:
                when += times[0] - now
                marks += ("delayed",)
            if faults.reorder and self._in_flight and chance() < faults.reorder:
                when = max(when, max(entry[0] for entry in self._in_flight))
                marks += ("reordered",)
        delivery = _Delivery(raw, packet, to_requester, concatenated, marks)
        if concatenated:
            # Nothing may come between an ack and its concatenated response.
            self._deliver(delivery)
        else:
            self._schedule(when, delivery)
        if len(times) > 1:  # the copy right behind the packet
            copy = delivery._replace(concatenated=False, faults=(*marks, "duplicate"))
            self._schedule(when, copy)

    def _schedule(self, when: float, delivery: _Delivery) -> None:
        self._sequence += 1
        heapq.heappush(self._in_flight, (when, self._sequence, delivery))

    def _flip_one_bit(self, raw: bytes) -> bytes:
        bit = self.random.randrange(8 * len(raw))
        damaged = bytearray(raw)
        damaged[bit // 8] ^= 0x80 >> bit % 8
        return bytes(damaged)

    # -- arriving ----------------------------------------------------------------------
    def _deliver(self, delivery: _Delivery) -> None:
        if delivery.to_requester:
            self._deliver_response(delivery)
        else:
            self._deliver_request(delivery)

    def _deliver_request(self, delivery: _Delivery) -> None:
        now, request = self.now, delivery.packet
        self._record_packet(now, request, False, False, delivery.faults, delivery.raw)
        # Decoded once for all the nodes, as every node's link sees the same bits.
        received, damaged = decode_received(delivery.raw)
        replies = (
            [(r, r.receive_packet(received, now, damaged=damaged)) for r in self.responders]
            if received is not None
            else []
        )
        acked = [(r, reply.ack) for r, reply in replies if reply.ack is not None]
        if is_broadcast(request.destination_id) and isinstance(request, _WRITES):
            # Nobody acks a broadcast write, and the requester waits for no ack; a
            # node that acks misbehaves, and the wire shows it.
            for responder, ack in acked:
                self._record_ack(now, responder.node_id, ack, ())
        else:
            self._report_ack(request, acked[0] if acked else None)
        for _, reply in replies:
            if reply.response is not None:
                assert isinstance(reply.response, RoutedPacket)
                self._send(reply.response, now, to_requester=True, concatenated=reply.concatenated)

    def _report_ack(self, request: RoutedPacket, acked: tuple[Responder, int] | None) -> None:
        now = self.now
        heard: int | None = None
        if acked is None:
            self._record(Exchange(now, "no_ack", request.destination_id, request.source_id))
        else:
            responder, heard = acked
            lose = self.faults.lose_ack
            lost = bool(lose) and self.random.random() < lose
            self._record_ack(now, responder.node_id, heard, ("lost",) if lost else ())
            if lost:
                heard = None
        if heard is not None or self.report_missing_acks:
            self.requester.receive_ack(request.destination_id, request.tlabel, heard, now)

    def _deliver_response(self, delivery: _Delivery) -> None:
        now, response = self.now, delivery.packet
        packet = decode_sound(delivery.raw)
        if packet is None:
            # The requester's link discards a packet that fails its checks.
            marks = (*delivery.faults, "discarded")
            self._record_packet(now, response, True, delivery.concatenated, marks, delivery.raw)
            return
        self._record_packet(
            now, response, True, delivery.concatenated, delivery.faults, delivery.raw
        )
        ack = self.requester.receive_response(packet, now)
        if ack is not None:
            self._record(Exchange(now, "ack", self.requester.node_id, response.source_id, ack=ack))

    # -- the trace ---------------------------------------------------------------------
    def _record(self, exchange: Exchange) -> None:
        if self.keep_trace:
            self.trace.append(exchange)

    def _record_packet(
        self,
        now: float,
        packet: RoutedPacket,
        to_requester: bool,
        concatenated: bool,
        faults: tuple[str, ...],
        raw: bytes = b"",
    ) -> None:
        kind = "response" if to_requester else "request"
        corrupted = raw if "corrupted" in faults or "tampered" in faults else b""
        self._record(
            Exchange(
                now,
                kind,
                packet.source_id,
                packet.destination_id,
                packet=packet,
                concatenated=concatenated,
                faults=faults,
                raw=corrupted,
            )
        )

    def _record_ack(
        self, now: float, source: int, ack: int | None, faults: tuple[str, ...]
    ) -> None:
        self._record(Exchange(now, "ack", source, self.requester.node_id, ack=ack, faults=faults))
