"""Second copies of a frame: a host takes each answer once.

A medium may deliver a frame twice (a duplicating network, a member's fault
injection) or late. Labels alone cannot tell a copy from a new answer: a host
with every transaction label to a node in use hands a label out again the
moment its transaction ends, and the copy of that transaction's answer, a
moment behind the original, then carries the label, source and tcode of the
new transaction and would complete it with the old data. (At more than 64
outstanding reads to one node, with 5 % duplication, about 1 read in 170 got
another read's data that way.) A copy is the same datagram, though: same
sender member and same frame sequence number. :class:`RecentFrames` remembers
the latest sequence numbers of each sender and :class:`HostLink` drops a
frame it has taken before, counting it in :attr:`HostLink.copies`.

A copy of a *request* draws a second answer, a frame of its own. Its ack
names the request's frame sequence number, though, as every ack does: the
link remembers the sequence number each label last went out in and drops an
ack (with any response behind it) that names another, counting it in
:attr:`HostLink.stale_acks`. A split response to a copied request carries
nothing to tell it apart: only the engine's label holds guard against it.
A keyed bus drops copies before all this (as replays); this is the insecure
bus's guard.
"""

from __future__ import annotations

from fw1394.engine import Requester
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import BROADCAST_ID, PHY_ID_MASK, phy_of
from fw1394.transport.link import ACK, ACK_SIZE, ASYNC_PACKET, RequesterLink, Send
from fw1394.transport.sansio.wire import ACK_PAYLOAD, FrameHeader
from fw1394.transport.station import Station

_unpack_ack = ACK_PAYLOAD.unpack_from

#: Sequence numbers remembered per sender: a copy later than this many newer frames
#: of the same sender is taken for a copy too (it can only be very late).
WINDOW = 4096
_SEQUENCE = 0xFFFFFFFF
_HALF = 1 << 31


class RecentFrames:
    """Which (sender, sequence) frames were taken, over the last :data:`WINDOW` per sender."""

    __slots__ = ("_highest", "_marks")

    def __init__(self) -> None:
        #: sender member id -> the highest sequence number taken.
        self._highest: dict[int, int] = {}
        #: sender member id -> which were taken: the mark of sequence s is byte
        #: s % WINDOW, for the WINDOW sequences up to the highest. A ring of bytes
        #: rather than one integer of WINDOW bits: an answer moves it on by a byte,
        #: where shifting the integer copies all 512 of its bytes.
        self._marks: dict[int, bytearray] = {}

    def again(self, sender: int, sequence: int) -> bool:
        """Whether frame ``sequence`` of ``sender`` came before; records it if not."""
        highest = self._highest.get(sender)
        if highest is None:
            marks = self._marks[sender] = bytearray(WINDOW)
            marks[sequence % WINDOW] = 1
            self._highest[sender] = sequence
            return False
        marks = self._marks[sender]
        # Sequence numbers are 32 bits and wrap: compared as serial numbers (RFC 1982).
        ahead = (sequence - highest) & _SEQUENCE
        if 0 < ahead < _HALF:
            if ahead >= WINDOW:
                marks[:] = bytes(WINDOW)
            elif ahead > 1:
                # The sequences skipped over leave the window's far end unmarked.
                start, end = (highest + 1) % WINDOW, sequence % WINDOW
                if start <= end:
                    marks[start:end] = bytes(end - start)
                else:
                    marks[start:] = bytes(WINDOW - start)
                    marks[:end] = bytes(end)
            marks[sequence % WINDOW] = 1
            self._highest[sender] = sequence
            return False
        back = (highest - sequence) & _SEQUENCE
        index = sequence % WINDOW
        if back >= WINDOW or marks[index]:
            return True
        marks[index] = 1
        return False

    def forget(self, sender: int) -> None:
        self._highest.pop(sender, None)
        self._marks.pop(sender, None)


class HostLink(RequesterLink):
    """A requester's link that takes every data frame once."""

    def __init__(self, requester: Requester, send: Send, station: Station | None = None) -> None:
        super().__init__(requester, send, station)
        self.recent = RecentFrames()
        #: (physical ID << 6 | label) -> the frame sequence number it last went out in.
        self.asked: dict[int, int] = {}
        #: Second copies dropped, and acks of a request frame that is not the label's.
        self.copies = self.stale_acks = 0

    def receive(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if self.recent.again(header.sender, header.sequence):
            self.copies += 1
            return
        super().receive(header, payload, now)

    def take(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if header.kind == ACK and len(payload) >= ACK_SIZE:
            _, tlabel, _, acked = _unpack_ack(payload)
            if self.asked.get((header.sender_phy & PHY_ID_MASK) << 6 | tlabel) != acked:
                self.stale_acks += 1  # the answer to a copy of an earlier request
                return
        super().take(header, payload, now)

    def flush(self) -> None:
        send, asked = self.send, self.asked
        for packet in self.requester.packets_to_send():
            destination = phy_of(getattr(packet, "destination_id", BROADCAST_ID))
            sequence = send(ASYNC_PACKET, destination, encode_packet(packet))
            if isinstance(sequence, int):
                asked[destination << 6 | getattr(packet, "tlabel", 0)] = sequence
