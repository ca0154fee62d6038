"""A client's read or write in one pass: request out, answer in, reply back.

Programs that drive boards through the adapter (the JHU host library's
FireWire port through libraw1394, :class:`~fw1394.host.adapter_port.AdapterPort`)
mostly run one blocking transaction at a time, and mostly it ends the common
way: a read acked ``ack_pending`` with its response concatenated behind the ack,
a write acked ``ack_complete``. The engine's general path makes a packet object
and a :class:`~fw1394.engine.transaction.Transaction`, queues, encodes, and ends
the transaction through its event queue; :class:`Express` runs that common case
on flat values instead, as :mod:`fw1394.transport.express` does for a blocking
host: label and transaction id from :meth:`Requester.begin
<fw1394.engine.Requester.begin>`, the wire bytes from
:func:`~fw1394.packets.fast.wire_builder`, the answer judged on the ack frame's
bytes (:func:`~fw1394.engine.requester.concatenated_data`), the end taken by
:meth:`Requester.finish <fw1394.engine.Requester.finish>`.

The adapter is an event loop, so the transaction in flight (a :class:`Flight`)
waits between its request and its answer while other things may happen. It
goes on the general way, handed to the requester as if started there
(:meth:`Requester.adopt <fw1394.engine.Requester.adopt>`), the moment anything
else does: a frame that is not its clean answer (served the general way after
the handover), a bus reset, any other request, the station's timers, or its
ack timeout. Anything that is not the common case (another transaction
outstanding, a broadcast, a lock, a block too long for one datagram, fault
injection) starts the general way.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Generic, TypeVar

from fw1394.engine.requester import concatenated_data
from fw1394.packets import AckCode, WriteResponse
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.frame import ACK_FRAME_FORMAT, ACK_FRAME_SIZE
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BASE
from fw1394.transport.bus_host import MAX_BLOCK_READ, MAX_BLOCK_WRITE, BusHost
from fw1394.transport.copies import HostLink
from fw1394.transport.express import READ_BLOCK, READ_QUADLET, WRITE_BLOCK, WRITE_QUADLET, Kind
from fw1394.transport.link import ACK, ASYNC_PACKET
from fw1394.transport.sansio.wire import FrameHeader

_pack_ack = ACK_FRAME_FORMAT.pack
_unpack_ack = ACK_FRAME_FORMAT.unpack_from


def _acked(payload: bytes) -> int:
    """The sequence number of the frame an ack frame's ``payload`` acks."""
    sequence: int = _unpack_ack(payload)[3]
    return sequence


_COMPLETE = ACK_BYTES[AckCode.ack_complete]
_OFFSET_LIMIT = 1 << 48
#: Whose a flight is (the adapter's client and request number): passed back, never used.
Owner = TypeVar("Owner")


@dataclass(slots=True)
class Flight(Generic[Owner]):
    """The one transaction on the express path: sent, its answer not yet in."""

    owner: Owner
    kind: Kind
    destination: int
    phy: int
    label: int
    #: The data length a read must bring (-1: any, as for a write or a quadlet read).
    length: int
    #: The request's fields after the route, to make its packet at a handover.
    values: tuple[int | bytes, ...]
    generation: int
    #: The frame sequence number the request went out in: its ack names it.
    sequence: int
    #: When it is handed to the requester if nothing came: its ack timeout.
    deadline: float


class Express(Generic[Owner]):
    """The express path of an adapter's host; see the module docstring."""

    def __init__(
        self,
        host: BusHost,
        link: HostLink,
        adopted: Callable[[int, Owner], None],
        answered: Callable[[Owner, bytes], None],
    ) -> None:
        self.host, self.link = host, link
        self.station, self.requester = host.station, host.requester
        #: Told of each flight handed to the requester: its transaction id, its owner.
        self.adopted = adopted
        #: Told of each flight that ended the common way, at once: its owner and its
        #: data (b"" for a write), before the ack of its response is sent.
        self.answered = answered
        self.flight: Flight[Owner] | None = None
        # Frames of a host with fault injection may leave late or twice.
        self.open = host.station.faults is None

    def start(
        self,
        owner: Owner,
        write: bool,
        quadlet: bool,
        node: int,
        offset: int,
        length: int,
        data: bytes,
    ) -> bool:
        """Send a read or write of the adapter protocol (``quadlet``, ``length``,
        ``data`` as the request carries them) to physical ID ``node``; False: take the
        general way (nothing was sent, or ``node`` is not plainly addressable)."""
        if self.flight is not None or not self.open or not 0 <= offset < _OFFSET_LIMIT:
            return False
        if not 0 <= node < BROADCAST_PHY:
            return False
        trailer = self.station.trailer_size
        values: tuple[int | bytes, ...]
        if write:
            if quadlet:
                if len(data) != 4:
                    return False
                kind, values = WRITE_QUADLET, (offset, int.from_bytes(data, "big"))
            else:
                if len(data) > MAX_BLOCK_WRITE - trailer:
                    return False
                kind, values = WRITE_BLOCK, (offset, bytes(data))
            expected = -1
        elif quadlet:
            kind, values, expected = READ_QUADLET, (offset,), -1  # as the requester's own
        else:
            if not 0 <= length <= MAX_BLOCK_READ - trailer:
                return False
            kind, values, expected = READ_BLOCK, (offset, length), length
        host, requester, station = self.host, self.requester, self.station
        destination = node | LOCAL_BASE
        # Catch up and check the pinned generation first, as the general start does.
        sent = host.on_bus()
        label = requester.begin(destination, sent)
        if label < 0:
            return False
        sequence = station.send(
            ASYNC_PACKET, node, kind[0](destination, label, requester.node_id, *values)
        )
        self.link.asked[node << 6 | label] = sequence  # whose ack is the one to take
        self.flight = Flight(
            owner,
            kind,
            destination,
            node,
            label,
            expected,
            values,
            station.generation,
            sequence,
            sent + requester.ack_timeout,
        )
        return True

    def take(self, header: FrameHeader, payload: bytes, now: float) -> bool:
        """Whether the frame ``header``, ``payload`` is the flight's clean answer (then
        the flight has ended); if not, the flight (if any) has been handed over and the
        frame is the general path's."""
        flight = self.flight
        if flight is None:
            return False
        if (
            header.kind == ACK
            and header.sender_phy == flight.phy
            and len(payload) >= ACK_FRAME_SIZE
            and payload[1] == flight.label
            and header.generation == flight.generation == self.station.generation
            # An ack names the request frame it acks: one naming another (the answer
            # to a copy of an earlier request) is the general path's to drop.
            and _acked(payload) == flight.sequence
        ):
            response_class = flight.kind[2]
            if response_class is WriteResponse:
                ok = payload[0] == _COMPLETE and len(payload) == ACK_FRAME_SIZE
                data: bytes | None = b"" if ok else None
            else:
                me = self.requester.node_id
                data = concatenated_data(
                    payload, flight.phy, response_class, flight.destination, flight.length, me
                )
            if data is not None:
                link = self.link
                if link.recent.again(header.sender, header.sequence):
                    link.copies += 1  # the frame came before: the general path's drop
                    return True
                self.requester.finish(now)
                self.flight = None
                self.answered(flight.owner, data)
                if response_class is not WriteResponse:  # the link acks the response
                    ack = _pack_ack(_COMPLETE, flight.label, 0, header.sequence)
                    link.send(ACK, flight.phy, ack)
                return True
        self.adopt()
        return False

    def adopt(self) -> None:
        """Hand the flight, if any, to the requester, in flight as if started there."""
        flight = self.flight
        if flight is None:
            return
        self.flight = None
        requester = self.requester
        packet = flight.kind[1](flight.destination, flight.label, requester.node_id, *flight.values)
        expects = flight.kind[2] is not WriteResponse
        tid = requester.adopt(packet, flight.length, expects)
        self.adopted(tid, flight.owner)
