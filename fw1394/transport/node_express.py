"""One pass for a node's turn: request frame in, ack frame (and response) out.

A node's loop spends a quadlet read mostly on its way through the layers: the
station unpacks the frame header into a :class:`~fw1394.transport.sansio.wire.FrameHeader`
and slices the payload, the link settles the turn, checks the generation and
hands the payload to the responder. :func:`node_turn` makes a turn that reads
the header's generation, sender and sequence number in place and hands a
request of the current generation straight to :meth:`Responder.serve
<fw1394.engine.Responder.serve>`, whose common case answers with the ack
frame's bytes; the link sends them (or the responder's :class:`Reply`) through
the station, as in the general turn.

Everything that is not a request of this generation from a member with a
physical ID takes the general path (:meth:`LinkLayer.settle
<fw1394.transport.link.LinkLayer.settle>` on :meth:`Station.take_opened
<fw1394.transport.station.Station.take_opened>`): a quiet poll, a frame dropped
by its MAC, bus management, PHY packets, acks, frames of another generation or
before this node has a physical ID. The station's timers run after the answer,
as in the general turn. A station with fault injection (frames may leave late
or twice) and a link of another class always take the general turn.
``tests/transport/test_node_express.py`` holds both turns equal.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from fw1394.packets.accessors import TLABEL
from fw1394.packets.nodeid import MAX_NODES
from fw1394.transport.link import ASYNC_PACKET, ResponderLink
from fw1394.transport.sansio.wire import HEADER, HEADER_SIZE, FrameHeader
from fw1394.transport.station import skipping

_clock = time.monotonic
_tlabel = TLABEL.of_bytes
#: The bytes every request frame starts with: magic, version, kind.
_REQUEST_PREFIX = FrameHeader(ASYNC_PACKET, 0, 0, 0, 0, 0).pack()[:4]
#: Generation, sender's physical ID and sequence number (fields 5, 6 and 10 of the
#: wire layout), read in place.
_ROUTE = skipping(HEADER, frozenset(range(11)) - {5, 6, 10})


def node_turn(link: ResponderLink) -> Callable[[], float]:
    """A function running one turn of ``link``'s station loop, as :meth:`link.turn
    <fw1394.transport.link.LinkLayer.turn>` does; returns the turn's clock reading."""
    station = link.station
    if (
        station is None
        or type(link) is not ResponderLink
        or station.faults is not None
        or link.send != station.send
    ):
        return link.turn
    receive = station.medium.receive
    # An insecure bus has no MAC to check: nothing to call.
    opened = None if station.dropped is None else station.open
    take = station.take_opened
    settle, service, answer, send_ack = link.settle, link.service, link.answer, link.send_ack
    membership = station.membership
    serve = link.responder.serve
    route = _ROUTE.unpack_from
    epoch = link.epoch

    def turn() -> float:
        raw = receive()
        now = _clock()  # when the frame arrived: one clock reading serves the turn
        if raw is not None and opened is not None:
            raw = opened(raw)  # None: forged or replayed, counted, never seen
        if raw is None:
            settle(None, now)
            return now
        if raw[:4] == _REQUEST_PREFIX and len(raw) >= HEADER_SIZE:
            generation, requester, sequence = route(raw)
            if (
                generation == membership.generation
                and membership.phy_id is not None
                and requester < MAX_NODES  # a sender with a physical ID
            ):
                payload = raw[HEADER_SIZE:]
                reply = serve(payload, sequence, now - epoch)
                if isinstance(reply, bytes):
                    send_ack(reply, requester)  # the response, if any, behind the ack
                elif reply.ack is not None or reply.response is not None:
                    answer(reply, _tlabel(payload), requester, sequence)
                # The timers of the general turn; no frame waits to leave late
                # (station.wake_by) where no fault is injected.
                if now >= link.due:
                    service(now)
                return now
        settle(take(raw), now)
        return now

    return turn
