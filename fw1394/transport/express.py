"""One pass for a blocking transaction: request out, answer in, data back.

:class:`~fw1394.host.bus_port.BusPort`'s blocking calls mostly run one
transaction at a time, and mostly that transaction ends the common way: a read
acked ``ack_pending`` with its response concatenated behind the ack, a write
acked ``ack_complete``. The general path still makes a request packet and a
:class:`~fw1394.engine.transaction.Transaction`, queues the packet, encodes
it, and then pumps the link, which ends the transaction through the engine's
events. :class:`Express` does that common turn on flat values instead: label
and transaction id from :meth:`Requester.begin <fw1394.engine.Requester.begin>`,
the request's wire bytes from :func:`~fw1394.packets.fast.wire_builder`, one
receive, the answer judged on the ack frame's bytes
(:func:`~fw1394.engine.requester.concatenated_data`), the end taken by
:meth:`Requester.finish <fw1394.engine.Requester.finish>`, the link's ack of
the response, and the rest of the turn as the host's loop does it (station
timers, catching up after a pause, engine timers).

Anything else goes the general way, with the transaction handed over to the
requester (:meth:`Requester.adopt <fw1394.engine.Requester.adopt>`) before the
frame that was not its clean answer is served: another frame first, a quiet
poll, a busy or error ack, an error rcode, a split response. So does a call
with anything else outstanding, a broadcast, an argument the general path would
refuse, and a host with fault injection (whose frames may be delayed or copied).
A keyed bus needs nothing special: the station seals and opens frames around
the same payloads. Locks always go the general way. ``tests/transport/test_express.py`` holds both
paths equal with hypothesis.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from fw1394.engine import ReadCompleted, TransactionEvent, TransactionFailed
from fw1394.engine.requester import concatenated_data
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    Request,
    WriteResponse,
)
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.fast import builder, wire_builder
from fw1394.packets.frame import ACK_FRAME_FORMAT, ACK_FRAME_SIZE
from fw1394.packets.nodeid import BROADCAST_ID, BROADCAST_PHY, LOCAL_BASE, phy_of
from fw1394.transport.bus_host import (
    MAX_BLOCK_READ,
    MAX_BLOCK_WRITE,
    BusHost,
    TransactionError,
)
from fw1394.transport.link import ACK, ASYNC_PACKET, BusRefusedError

_clock = time.monotonic
_pack_ack = ACK_FRAME_FORMAT.pack
_COMPLETE = ACK_BYTES[AckCode.ack_complete]
_OFFSET_LIMIT = 1 << 48
_QUADLET_LIMIT = 1 << 32
#: Node IDs are 16 bits; the largest, all ones, is the local broadcast.
_LAST_NODE = BROADCAST_ID
#: A request kind (also used by the host adapter's express path): its wire bytes from
#: the route and its own fields; the packet object the requester would have made of
#: the same values, should the general path take over; and the response class that
#: ends it (a write: WriteResponse, which the express path takes as "ended by
#: ack_complete alone").
Kind = tuple[Callable[..., bytes], Callable[..., Request], type[AsyncPacket]]
_ROUTE = ("destination_id", "tlabel", "source_id", "offset")


def _kind(cls: type[Request], response: type[AsyncPacket], *names: str) -> Kind:
    return wire_builder(cls, *_ROUTE, *names), builder(cls, *_ROUTE, *names), response


READ_QUADLET = _kind(QuadletReadRequest, QuadletReadResponse)
READ_BLOCK = _kind(BlockReadRequest, BlockReadResponse, "data_length")
WRITE_QUADLET = _kind(QuadletWriteRequest, WriteResponse, "quadlet_data")
WRITE_BLOCK = _kind(BlockWriteRequest, WriteResponse, "data")


class Express:
    """The one-pass blocking calls of ``host``; see the module docstring."""

    def __init__(self, host: BusHost) -> None:
        self.host = host
        self.station = host.station
        self.link = host.link
        self.requester = host.requester
        # Frames of a host with fault injection may leave late or twice.
        self.open = host.station.faults is None

    def read_quadlet(self, node: int, offset: int) -> int:
        if self.open and 0 <= node <= _LAST_NODE and 0 <= offset < _OFFSET_LIMIT:
            data = self._run(node, READ_QUADLET, -1, offset)
            if data is not None:
                return int.from_bytes(data)
        host = self.host
        return int.from_bytes(_data(host.wait(host.start_read_quadlet(node, offset))))

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        limit = MAX_BLOCK_READ - self.station.trailer_size
        plain = 0 <= node <= _LAST_NODE and 0 <= offset < _OFFSET_LIMIT and 0 <= length <= limit
        if self.open and plain:
            data = self._run(node, READ_BLOCK, length, offset, length)
            if data is not None:
                return data
        host = self.host
        return _data(host.wait(host.start_read_block(node, offset, length)))

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        plain = 0 <= node <= _LAST_NODE and 0 <= offset < _OFFSET_LIMIT
        plain = plain and 0 <= value < _QUADLET_LIMIT
        if not (self.open and plain) or self._run(node, WRITE_QUADLET, -1, offset, value) is None:
            host = self.host
            _data(host.wait(host.start_write_quadlet(node, offset, value)))

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        limit = MAX_BLOCK_WRITE - self.station.trailer_size
        plain = 0 <= node <= _LAST_NODE and 0 <= offset < _OFFSET_LIMIT and len(data) <= limit
        if (
            not (self.open and plain)
            or self._run(node, WRITE_BLOCK, -1, offset, bytes(data)) is None
        ):
            host = self.host
            _data(host.wait(host.start_write_block(node, offset, data)))

    def _run(self, node: int, kind: Kind, length: int, *values: int | bytes) -> bytes | None:
        """The data of one transaction (b"" for a write), whichever way it ended.

        ``values`` are the request's fields after the route, ``length`` the data
        a read must bring (-1: any). Raises :class:`TransactionError` if the
        transaction failed. None: the requester could not take it on alone
        (something else is outstanding, or every label to the node is held), and
        nothing was sent.
        """
        host, requester, station = self.host, self.requester, self.station
        # A physical ID alone names the local bus (63 broadcasts: the general way).
        destination = node | LOCAL_BASE if node <= BROADCAST_PHY else node
        # Catch up first, as the general start does: back from a pause, the bus may
        # have dropped this host, and nothing may go out in a stale generation.
        sent = host.on_bus()
        label = requester.begin(destination, sent)
        if label < 0:
            return None
        me = requester.node_id
        phy = phy_of(destination)
        wire, packet, response_class = kind
        sequence = station.send(ASYNC_PACKET, phy, wire(destination, label, me, *values))
        self.link.asked[phy << 6 | label] = sequence  # whose ack is the one to take
        frame = station.receive()
        now = _clock()  # when the frame arrived, as in the link's turn
        if frame is not None:
            header, payload = frame
            if (
                header.kind == ACK
                and header.sender_phy == phy
                and len(payload) >= ACK_FRAME_SIZE
                and payload[1] == label
                and header.generation == station.membership.generation
            ):
                if response_class is WriteResponse:
                    ok = payload[0] == _COMPLETE and len(payload) == ACK_FRAME_SIZE
                    data: bytes | None = b"" if ok else None
                else:
                    data = concatenated_data(payload, phy, response_class, destination, length, me)
                if data is not None:
                    requester.finish(now)
                    self.link.recent.again(header.sender, header.sequence)  # a copy is no news
                    if response_class is not WriteResponse:  # the link acks the response
                        station.send(ACK, phy, _pack_ack(_COMPLETE, label, 0, header.sequence))
                    try:
                        self.link.keep_timers(now)
                    except BusRefusedError as error:
                        raise host.refused(error) from None
                    host.after_turn(now)
                    return data
        # Not the common end: the requester takes the transaction over, as if it had
        # started it the general way, and the frame is served the general way.
        expects = response_class is not WriteResponse
        tid = requester.adopt(packet(destination, label, me, *values), length, expects)
        try:
            self.link.settle(frame, now)
        except BusRefusedError as error:
            raise host.refused(error) from None
        host.after_turn(now)
        return _data(host.wait(tid))


def _data(event: TransactionEvent) -> bytes:
    """The data a transaction's end brings (b"" for a write); raises if it failed."""
    if isinstance(event, TransactionFailed):
        raise TransactionError(event)
    return event.data if isinstance(event, ReadCompleted) else b""
