"""One pass for a node's turn: request frame in, ack frame (and response) out.

A node's loop spends a quadlet read mostly on its way through the layers: the
station unpacks the frame header into a :class:`~fw1394.transport.wire.FrameHeader`
and slices the payload, the link settles the turn, checks the generation and
hands the payload to the responder, whose answer goes back down through the
link's sender and the station's, which packs a new header. :func:`node_turn`
makes a turn that does the common case on flat values in one function: the
header's generation, sender and sequence number read in place, the request
handed straight to the :class:`~fw1394.engine.fast_responder.FastResponder`
handler of its transaction code, and the ack frame packed and put on the
medium, with the station's own sequence numbers and (on a keyed bus) its seal.

Everything else takes the general path (:meth:`LinkLayer.settle
<fw1394.transport.link.LinkLayer.settle>` on :meth:`Station.take_opened
<fw1394.transport.station.Station.take_opened>`) before anything has changed:
a quiet poll, a frame dropped by its MAC, bus management, PHY packets, acks,
frames of another generation or before this node has a physical ID, request
kinds the fast responder does not serve, and requests it declines. A request it
refused, and an answer no datagram carries, end as the link ends them. The
station's timers run after the answer, as in the general turn. A station with
fault injection (frames may leave late or twice), a responder with planted
defects and a link of another class always take the general path.
``tests/transport/test_node_express.py`` holds both paths equal.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from fw1394.engine.responder import Reply
from fw1394.packets import Speed
from fw1394.packets.accessors import TLABEL
from fw1394.packets.layouts import TCODE_BYTE, TCODE_SHIFT
from fw1394.transport.link import ACK, ASYNC_PACKET, ResponderLink
from fw1394.transport.sansio.wire import HEADER, HEADER_SIZE, MAGIC, VERSION, FrameHeader
from fw1394.transport.station import skipping

_clock = time.monotonic
_tlabel = TLABEL.of_bytes
#: The bytes every request frame starts with: magic, version, kind.
_REQUEST_PREFIX = FrameHeader(ASYNC_PACKET, 0, 0, 0, 0, 0).pack()[:4]
#: Generation, sender's physical ID and sequence number (fields 5, 6 and 10 of the
#: wire layout), read in place.
_ROUTE = skipping(HEADER, frozenset(range(11)) - {5, 6, 10})
_TCODE_AT = HEADER_SIZE + TCODE_BYTE
_S400 = int(Speed.S400)
_SEQUENCE_MASK = 0xFFFFFFFF


def node_turn(link: ResponderLink) -> Callable[[], float]:
    """A function running one turn of ``link``'s station loop, as :meth:`link.turn
    <fw1394.transport.link.LinkLayer.turn>` does; returns the turn's clock reading."""
    station = link.station
    fast = link.fast
    if (
        station is None
        or fast is None
        or type(link) is not ResponderLink
        or station.faults is not None
        or link.send != station.send
    ):
        return link.turn
    receive = station.medium.receive
    verifier = station._verifier
    opened = None if verifier is None else verifier.open
    take = station.take_opened
    settle, service, answer, send_ack = link.settle, link.service, link.answer, link.send_ack
    membership = station.membership
    handlers = fast.handlers
    put, sequences = station._put, station._sequence
    tag, member, limit = station._tag, station._member_id, station._max_payload
    route, pack = _ROUTE.unpack_from, HEADER.pack
    epoch = link.epoch

    def turn() -> float:
        raw = receive()
        now = _clock()  # when the frame arrived: one clock reading serves the turn
        if raw is not None and opened is not None:
            raw = opened(raw)  # None: forged or replayed, counted, never seen
        if raw is None:
            settle(None, now)
            return now
        if raw[:4] == _REQUEST_PREFIX and len(raw) > _TCODE_AT:
            generation, requester, sequence = route(raw)
            phy = membership.phy_id
            handler = handlers.get(raw[_TCODE_AT] >> TCODE_SHIFT)
            if generation == membership.generation and phy is not None and handler is not None:
                payload = raw[HEADER_SIZE:]
                reply = handler(payload, sequence, now - epoch)
                if reply is not None:
                    if not isinstance(reply, Reply):
                        if len(reply) <= limit:
                            number = next(sequences) & _SEQUENCE_MASK
                            head = pack(
                                MAGIC, VERSION, ACK, tag, member, generation, phy, requester,
                                _S400, 0, number,
                            )  # fmt: skip
                            put(head + reply)
                        else:
                            send_ack(reply, requester)  # drops the response, sends the ack
                    else:  # a refusal: the reference's reply
                        answer(reply, _tlabel(payload), requester, sequence)
                    # The timers of the general turn; no frame waits to leave late
                    # (station.wake_by) where no fault is injected.
                    if now >= link.due:
                        service(now)
                    return now
        settle(take(raw), now)
        return now

    return turn
