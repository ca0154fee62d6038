"""The link layer: where bus frames meet the transaction engine.

Every bus member and tunnel end speaks the same link protocol
(``docs/virtual-bus.md``): a request goes out as an ``async_packet`` frame;
the responder answers with an ``ack`` frame naming the request frame's
sequence number (the response concatenated behind the ack when its policy
answers in the same bus tenure), or with the ack and later a split response
of its own, which the requester acks in turn. This module is that protocol,
once, for both roles:

* :class:`ResponderLink` takes request frames, runs a
  :class:`~fw1394.engine.Responder` and sends its ack (and response);
* :class:`RequesterLink` sends a :class:`~fw1394.engine.Requester`'s packets
  and turns ack frames, concatenated responses and split responses into
  engine calls.

Both share :class:`LinkLayer`: one turn of a station's loop (receive, keep the
membership's timers), the generation check every received frame passes, and
the bus-reset hooks that give the engine its new node ID and generation. A
link made without a station (a point-to-point tunnel) uses :meth:`LinkLayer.take`
directly with the frames it reads itself.

The common turn is plain ints and bytes: a sender is ``send(kind,
destination_phy, payload)``, the station's own :meth:`Station.send`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable

from fw1394.engine import Requester, Responder
from fw1394.engine.responder import Reply
from fw1394.errors import BusUnreachable
from fw1394.packets import AckCode, AsyncPacket
from fw1394.packets.accessors import TLABEL
from fw1394.packets.fast import decode_sound, encode_packet
from fw1394.packets.nodeid import BROADCAST_ID, node_id, phy_of
from fw1394.transport.sansio.membership import BusReset, Change, Excluded, Refused
from fw1394.transport.sansio.wire import (
    ACK_PAYLOAD,
    FrameHeader,
    FrameKind,
    FrameTooLarge,
    ack_byte,
)
from fw1394.transport.station import Station

#: Puts a frame on the link: kind, destination physical ID, payload.
Send = Callable[[int, int, bytes], object]
# Plain ints: an Enum member lookup costs more than the rest of a frame's dispatch.
ASYNC_PACKET, ACK = int(FrameKind.async_packet), int(FrameKind.ack)
#: Wire byte of each ack code (code and parity), looked up rather than computed.
ACK_BYTES = tuple(ack_byte(code) for code in range(16))
ACK_SIZE = ACK_PAYLOAD.size
ACK_COMPLETE_BYTE = ACK_BYTES[AckCode.ack_complete]
_pack_ack = ACK_PAYLOAD.pack
_unpack_ack = ACK_PAYLOAD.unpack_from
_clock = time.monotonic
_tlabel = TLABEL.of_bytes


class BusRefusedError(BusUnreachable):
    """The coordinator would not take this member (the bus already has 63)."""


class LinkLayer:
    """What both roles share: a station's loop, generation checks, reset hooks."""

    def __init__(self, send: Send, station: Station | None = None) -> None:
        self.send = send
        self.station = station
        #: When the station's timers are next due (monotonic seconds).
        self.due = 0.0
        #: Called with each bus reset this member takes part in (logs, board state).
        self.on_reset: Callable[[BusReset], None] | None = None
        #: Called whenever the engine took something in: a frame, or a reset (its
        #: owner collects the engine's events then).
        self.on_progress: Callable[[], None] | None = None

    # -- the roles fill these in -------------------------------------------------------
    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        """A data frame of the current generation, received at ``now`` (monotonic)."""

    def bus_reset(self, *, phy: int, generation: int) -> None:
        """The engine's side of a bus reset: physical ID ``phy`` in ``generation``."""

    def excluded(self, *, generation: int) -> None:
        """A reset left this member out; it is rejoining."""

    # -- a station's loop --------------------------------------------------------------
    def turn(self) -> float:
        """Receive one frame (or wait out a quiet poll), serve it, keep the timers; now."""
        frame = self._station().receive()
        now = _clock()  # when the frame arrived: one clock reading serves the turn
        self.settle(frame, now)
        return now

    def settle(self, frame: tuple[FrameHeader, bytes] | None, now: float) -> None:
        """The rest of a turn: serve ``frame`` (None: a quiet poll) that came at ``now``,
        and keep the timers."""
        station = self._station()
        if frame is None:
            # Bus management (or a quiet poll): the engine must learn its new node ID
            # before the first packet of a new generation is answered or sent.
            self.apply_changes()
            self.due = min(self.due, station.next_deadline())
        else:
            self.receive(frame[0], frame[1], now)
        self.keep_timers(now)

    def keep_timers(self, now: float) -> None:
        """Run the station's timers if any is due at ``now``."""
        if now >= self.due or now >= self._station().wake_by:
            self.service(now)

    def receive(self, header: FrameHeader, payload: bytes, now: float) -> None:
        """A data frame from the station: taken if it is of this member's generation."""
        membership = self._station().membership
        # A packet of another generation never reaches a link after a reset.
        if header.generation == membership.generation and membership.phy_id is not None:
            self.take(header, payload, now)

    def service(self, now: float | None = None) -> None:
        """Run the station's timers now, and take in what they changed."""
        station = self._station()
        station.service(now)
        self.apply_changes()
        self.due = station.next_deadline()

    def apply_changes(self) -> None:
        """Take the station's membership changes (bus resets) into the engine."""
        self.apply(self._station().changes())

    def apply(self, changes: Iterable[Change]) -> None:
        for change in changes:
            if isinstance(change, BusReset):
                self.bus_reset(phy=change.phy_id, generation=change.generation)
                if self.on_reset is not None:
                    self.on_reset(change)
            elif isinstance(change, Excluded):
                self.excluded(generation=change.generation)
            elif isinstance(change, Refused):
                raise BusRefusedError(change.reason)
        if self.on_progress is not None:
            self.on_progress()

    def _station(self) -> Station:
        if self.station is None:
            raise RuntimeError("this link has no station: feed it frames with take()")
        return self.station


class ResponderLink(LinkLayer):
    """A responder behind a link: request frames in, acks and responses out.

    ``epoch`` is subtracted from the monotonic time of each request before the
    responder sees it (the board's clock counts from its node's start).
    ``on_drop`` hears of each response no datagram could carry.
    """

    def __init__(
        self,
        responder: Responder,
        send: Send,
        station: Station | None = None,
        *,
        epoch: float = 0.0,
        on_drop: Callable[[int, FrameTooLarge], None] | None = None,
    ) -> None:
        super().__init__(send, station)
        self.responder = responder
        self.epoch = epoch
        self.on_drop = on_drop

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if header.kind == ASYNC_PACKET:
            self.serve(payload, header.sender_phy, header.sequence, now)

    def serve(self, payload: bytes, requester: int, sequence: int, now: float) -> bytes | Reply:
        """Answer the packet ``payload`` that came in frame ``sequence`` from ``requester``;
        the responder's answer (see :meth:`Responder.serve`)."""
        answer = self.responder.serve(payload, sequence, now - self.epoch)
        if isinstance(answer, bytes):
            self.send_ack(answer, requester)
        elif answer.ack is not None or answer.response is not None:
            self.answer(answer, _tlabel(payload), requester, sequence)
        return answer

    def send_ack(self, frame: bytes, requester: int) -> None:
        """Send an ack frame's payload (the response may be behind the ack)."""
        try:
            self.send(ACK, requester, frame)
        except FrameTooLarge as error:
            self._drop(requester, error)
            self.send(ACK, requester, frame[:ACK_SIZE])  # the ack alone still goes out

    def serve_packet(
        self, packet: AsyncPacket, damaged: bool, requester: int, sequence: int, now: float
    ) -> Reply:
        """:meth:`serve` for a packet already decoded; the responder's reply."""
        reply = self.responder.receive_packet(packet, now - self.epoch, damaged=damaged)
        if reply.ack is not None or reply.response is not None:
            self.answer(reply, getattr(packet, "tlabel", 0), requester, sequence)
        return reply

    def answer(self, reply: Reply, tlabel: int, requester: int, sequence: int) -> None:
        """Send ``reply`` to a request labelled ``tlabel`` that came in frame ``sequence``."""
        send = self.send
        response = b"" if reply.response is None else encode_packet(reply.response)
        if reply.ack is not None:
            ack = _pack_ack(ACK_BYTES[reply.ack], tlabel, 0, sequence)
            if reply.concatenated:
                try:
                    send(ACK, requester, ack + response)
                    return
                except FrameTooLarge as error:
                    self._drop(requester, error)
                    response = b""  # the ack alone still goes out
            send(ACK, requester, ack)
        if response:
            try:
                send(ASYNC_PACKET, requester, response)
            except FrameTooLarge as error:
                self._drop(requester, error)

    def bus_reset(self, *, phy: int, generation: int) -> None:
        self.responder.bus_reset(node_id=node_id(phy), generation=generation)

    def _drop(self, requester: int, error: FrameTooLarge) -> None:
        # The board answered (a real FPGA sends any length it is asked for) but no
        # datagram carries the answer: it is lost as on an overrun link, and the loss
        # is reported rather than silent. The requester's transaction times out.
        if self.on_drop is not None:
            self.on_drop(requester, error)


class RequesterLink(LinkLayer):
    """A requester behind a link: its packets out, acks and responses in."""

    def __init__(self, requester: Requester, send: Send, station: Station | None = None) -> None:
        super().__init__(send, station)
        self.requester = requester

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        kind = header.kind
        if kind == ACK:
            self.on_ack(header.sender_phy, header.sequence, payload, now)
        elif kind == ASYNC_PACKET:
            self.on_response(header.sender_phy, header.sequence, payload, now)
        else:
            return
        if self.on_progress is not None:
            self.on_progress()

    def on_ack(self, sender: int, sequence: int, payload: bytes, now: float) -> None:
        """Ack frame ``sequence`` from physical ID ``sender``, maybe with a response behind."""
        if len(payload) < ACK_SIZE:
            # Too short to name a transaction: dropped and counted, never the end
            # of this member (whoever sent it: a member with a bug, or anyone on
            # an insecure bus).
            if self.station is not None:
                self.station.drops.malformed += 1
            return
        label = self.requester.take_ack_frame(sender, payload, now)
        if label >= 0:
            # The response of the same tenure, acked like a split one (the link acks
            # whatever response it takes) under the ack frame's sequence number.
            self.send(ACK, sender, _pack_ack(ACK_COMPLETE_BYTE, label, 0, sequence))
        self.flush()  # an end may have freed a label, a busy ack queued a retry

    def on_response(self, sender: int, sequence: int, payload: bytes, now: float) -> None:
        """A response packet from ``sender`` in frame ``sequence``, acked if the engine says so."""
        # A response that fails its CRC or length checks is discarded unacked, as
        # a 1394 link discards it: its label, source or data cannot be trusted,
        # and completing a transaction with it would hand the caller wrong bytes.
        packet = decode_sound(payload)
        if packet is not None:
            code = self.requester.receive_response(packet, now)
            if code is not None:
                tlabel: int = getattr(packet, "tlabel", 0)
                self.send(ACK, sender, _pack_ack(ACK_BYTES[code], tlabel, 0, sequence))
        self.flush()  # the end may have freed a label a waiting request needs

    def flush(self) -> None:
        """Send every packet the requester has queued."""
        send = self.send
        for packet in self.requester.packets_to_send():
            destination = phy_of(getattr(packet, "destination_id", BROADCAST_ID))
            send(ASYNC_PACKET, destination, encode_packet(packet))

    def bus_reset(self, *, phy: int, generation: int) -> None:
        self.requester.bus_reset(generation=generation, node_id=node_id(phy))

    def excluded(self, *, generation: int) -> None:
        self.requester.bus_reset(generation=generation)
