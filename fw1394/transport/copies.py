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
frame it has taken before, counting it in :attr:`HostLink.copies`. A keyed
bus drops copies before this (as replays); this is the insecure bus's guard.
"""

from __future__ import annotations

from fw1394.engine import Requester
from fw1394.transport.link import RequesterLink, Send
from fw1394.transport.station import Station
from fw1394.transport.wire import FrameHeader

#: Sequence numbers remembered per sender: a copy later than this many newer frames
#: of the same sender is taken for a copy too (it can only be very late).
WINDOW = 4096
_MASK = (1 << WINDOW) - 1


class RecentFrames:
    """Which (sender, sequence) frames were taken, over the last :data:`WINDOW` per sender."""

    __slots__ = ("_senders",)

    def __init__(self) -> None:
        #: sender member id -> (highest sequence taken, bit k: highest - k taken).
        self._senders: dict[int, tuple[int, int]] = {}

    def again(self, sender: int, sequence: int) -> bool:
        """Whether frame ``sequence`` of ``sender`` came before; records it if not."""
        known = self._senders.get(sender)
        if known is None:
            self._senders[sender] = (sequence, 1)
            return False
        highest, taken = known
        if sequence > highest:
            self._senders[sender] = (sequence, (taken << (sequence - highest) | 1) & _MASK)
            return False
        back = highest - sequence
        if back >= WINDOW or taken >> back & 1:
            return True
        self._senders[sender] = (highest, taken | 1 << back)
        return False

    def forget(self, sender: int) -> None:
        self._senders.pop(sender, None)


class HostLink(RequesterLink):
    """A requester's link that takes every data frame once."""

    def __init__(self, requester: Requester, send: Send, station: Station | None = None) -> None:
        super().__init__(requester, send, station)
        self.recent = RecentFrames()
        #: Second copies dropped.
        self.copies = 0

    def receive(self, header: FrameHeader, payload: bytes, now: float) -> None:
        if self.recent.again(header.sender, header.sequence):
            self.copies += 1
            return
        super().receive(header, payload, now)
