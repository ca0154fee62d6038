"""A capture tap: a promiscuous listener that sees the whole bus as records.

The tap is not a member (it gets no physical ID and causes no bus reset); its
socket filter passes every frame of the bus, as a bus analyser's PHY passes
every packet. Asynchronous packets are held back briefly (``ack_wait``) so
that the ack that followed can be joined to them; records come out in the
order the packets were seen, each with its kernel arrival time in ns.

A busy bus does not wake the tap for every frame: while frames keep coming
(the last one less than ``QUIET_AFTER`` ago) the tap takes whatever is queued
and then sleeps ``BATCH_INTERVAL``, so that a capture beside a 1 kHz servo
loop costs a few wake-ups per cycle instead of one per packet, and leaves the
CPU to the members whose latency is being measured. The kernel stamps every
frame on arrival, so batching delays records, never changes their times. An
idle bus puts the tap back to sleep in ``recv`` until the next frame.

On a keyed bus the tap verifies every frame's MAC as the members do: a frame
without a valid one (a forgery, or a replay) is not recorded, and counted in
:attr:`BusTap.dropped`. Without the key it records nothing of a keyed bus.
"""

from __future__ import annotations

import math
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass

from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.packets.ack import ack_code
from fw1394.transport.media.choice import open_medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.seal import DropCounts, Verifier
from fw1394.transport.sansio.wire import (
    ACK_PAYLOAD,
    BROADCAST_PHY,
    HEADER_SIZE,
    NO_PHY,
    FrameError,
    FrameHeader,
    FrameKind,
    parse_header,
)
from fw1394.transport.supervision.bus_key import key_for

#: How long an asynchronous packet waits for its ack before it is passed on without.
DEFAULT_ACK_WAIT = 0.05
#: While the bus is busy, how long the tap sleeps once its queue is drained.
BATCH_INTERVAL = 0.005
#: How long after the last frame the bus counts as busy.
QUIET_AFTER = 0.05


@dataclass(slots=True)
class _Pending:
    """A record held back: its fields, made into a :class:`BusRecord` once, when it leaves."""

    timestamp_ns: int
    record_type: RecordType
    data: bytes
    generation: int
    sender: int | None
    speed: int
    #: (generation, sender physical ID, frame sequence) an ack would refer to; None: final.
    key: tuple[int, int, int] | None
    expires: float
    ack: int | None = None

    def record(self) -> BusRecord:
        return BusRecord(
            self.timestamp_ns,
            self.record_type,
            self.data,
            self.generation,
            self.sender,
            self.speed,
            ack=self.ack,
        )


class BusTap:
    """Every packet on bus ``bus_name`` as :class:`BusRecord` objects."""

    def __init__(
        self,
        bus_name: str,
        *,
        interface: str = "127.0.0.1",
        ack_wait: float = DEFAULT_ACK_WAIT,
        key: bytes | None = None,
    ) -> None:
        self.config = BusConfig(bus_name, interface=interface, key=key)
        self.ack_wait = ack_wait
        bus_key = key_for(self.config)
        self._verifier = None if bus_key is None else Verifier(bus_key)
        self.medium = open_medium(self.config, poll_interval=0.005)
        self.medium.filter_as_tap()
        self._queue: deque[_Pending] = deque()
        self._waiting: dict[tuple[int, int, int], _Pending] = {}
        self._last_stamp_ns = 0
        #: When the tap last took a frame (monotonic seconds).
        self._last_frame = -math.inf
        #: Until when a packet taken now waits for its ack (set per batch of frames).
        self._expires = -math.inf
        self._closed = False

    @property
    def dropped(self) -> DropCounts | None:
        """Frames not recorded for want of a valid MAC, or as replays; None: insecure bus."""
        return None if self._verifier is None else self._verifier.dropped

    def __enter__(self) -> BusTap:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if not self._closed:
            self._closed = True
            self.medium.close()

    def __iter__(self) -> Iterator[BusRecord]:
        while not self._closed:
            record = self.receive(0.1)
            if record is not None:
                yield record

    def receive(self, timeout: float) -> BusRecord | None:
        """The next record, or None if none is complete within ``timeout`` seconds."""
        clock = time.monotonic
        limit = clock() + timeout
        receive = self.medium.receive_stamped
        take = self._take
        while True:
            now = clock()
            ready = self._pop_ready(now)
            if ready is not None:
                return ready
            if now >= limit:
                return None
            busy = now - self._last_frame < QUIET_AFTER
            stamped = receive(wait=not busy)
            if stamped is not None:
                # Everything queued behind it comes in the same pass: one clock
                # reading for the batch, and the acks queued behind their packets
                # are joined to them before either is passed on.
                self._expires = clock() + self.ack_wait
                take(*stamped)
                while (stamped := receive(wait=False)) is not None:
                    take(*stamped)
                self._last_frame = clock()
            elif busy:
                time.sleep(min(BATCH_INTERVAL, limit - now))

    def _pop_ready(self, now: float) -> BusRecord | None:
        if not self._queue:
            return None
        head = self._queue[0]
        if head.key is not None and now < head.expires:
            return None
        self._queue.popleft()
        if head.key is not None:
            self._waiting.pop(head.key, None)
        return head.record()

    def _take(self, raw: bytes, stamp_ns: int) -> None:
        frame = raw if self._verifier is None else self._verifier.open(raw)
        if frame is None:
            return  # forged or replayed: counted
        try:
            header = parse_header(frame)
        except FrameError:
            return
        # The socket queue is the bus's order. Two members' frames can reach the
        # kernel on two CPUs within the same microsecond and be stamped the other way
        # round; on a cable one packet cannot start before the one ahead of it, so a
        # stamp never goes back (the difference is a few hundred nanoseconds).
        stamp_ns = max(stamp_ns, self._last_stamp_ns)
        self._last_stamp_ns = stamp_ns
        payload = frame[HEADER_SIZE:]
        sender = None if header.sender_phy == NO_PHY else header.sender_phy
        kind = header.kind
        generation, speed = header.generation, header.speed
        if kind == FrameKind.bus_reset:
            self._push(stamp_ns, RecordType.bus_reset, b"", generation, sender, speed, None)
        elif kind == FrameKind.phy_packet:
            self._push(stamp_ns, RecordType.phy_packet, payload, generation, sender, speed, None)
        elif kind == FrameKind.async_packet:
            acked = header.destination != BROADCAST_PHY and sender is not None
            key = (generation, header.sender_phy, header.sequence) if acked else None
            self._push(stamp_ns, RecordType.async_packet, payload, generation, sender, speed, key)
        elif kind == FrameKind.ack:
            self._take_ack(header, stamp_ns, sender, payload)

    def _take_ack(
        self, header: FrameHeader, stamp_ns: int, sender: int | None, payload: bytes
    ) -> None:
        # An ack frame goes to the sender of the packet it acknowledges.
        generation, acked_sender, speed = header.generation, header.destination, header.speed
        if len(payload) < ACK_PAYLOAD.size:
            return  # too short to be an ack (parse_ack's refusal)
        ack_byte, _, _, acked_sequence = ACK_PAYLOAD.unpack_from(payload)
        pending = self._waiting.pop((generation, acked_sender, acked_sequence), None)
        if pending is not None:
            pending.ack = ack_code(ack_byte)
            pending.key = None
        self._push(stamp_ns, RecordType.ack, bytes((ack_byte,)), generation, sender, speed, None)
        if len(payload) > ACK_PAYLOAD.size and sender is not None:
            # The response that rode in the same tenure; the requester acks it by the
            # sequence number of this ack frame.
            response = payload[ACK_PAYLOAD.size :]
            key = (generation, sender, header.sequence)
            self._push(stamp_ns, RecordType.async_packet, response, generation, sender, speed, key)

    def _push(
        self,
        stamp_ns: int,
        record_type: RecordType,
        data: bytes,
        generation: int,
        sender: int | None,
        speed: int,
        key: tuple[int, int, int] | None,
    ) -> None:
        pending = _Pending(
            stamp_ns, record_type, data, generation, sender, speed, key, self._expires
        )
        self._queue.append(pending)
        if key is not None:
            self._waiting[key] = pending
