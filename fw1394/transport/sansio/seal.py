"""Only members speak: every frame of a keyed bus ends with a counter and a keyed MAC.

A bus brought up by ``fw1394 bus up`` has a secret key (32 random bytes in its
runtime directory, mode 0600: :mod:`fw1394.transport.supervision.bus_key`).
Every member appends the trailer of :data:`fw1394.packets.frame.FRAME_TRAILER`
to each datagram it sends: a
per-sender counter and a BLAKE2s MAC keyed with the bus key over the whole
frame before it. A receiver drops, and counts, every frame whose MAC does not
verify (a forgery, or a member of the bus under another key) and every frame
whose counter it has already seen from that sender (a replay). The generation
is part of the MAC'd header, so a frame recorded in an earlier generation cannot
be made to look like one of this generation; recorded as it was, the replay
window drops it, and bus management ignores stale reset requests and leaves.
"""

from __future__ import annotations

import hashlib
import hmac
import struct
from dataclasses import dataclass
from itertools import count

from fw1394.packets.frame import (
    FRAME_COUNTER_FORMAT,
    FRAME_HEADER_SPANS,
    FRAME_MAC_SIZE,
    FRAME_TRAILER_SIZE,
)
from fw1394.transport.sansio.wire import HEADER_SIZE, SENDER_OFFSET

#: Counters seen per sender: a frame this far behind the newest is a replay.
REPLAY_WINDOW = 64
#: Senders remembered; the oldest is forgotten beyond this (a MAC'd frame is needed
#: to make an entry, so only members can fill it).
MAX_SENDERS = 4096
#: The sender field of the frame header, as wide as the layout makes it.
_SENDER = struct.Struct(">" + {2: "H", 4: "I"}[FRAME_HEADER_SPANS["sender"][1]])
_COUNTER = FRAME_COUNTER_FORMAT
_WINDOW_MASK = (1 << REPLAY_WINDOW) - 1


class Sealer:
    """Appends the trailer to each frame a member sends."""

    def __init__(self, key: bytes) -> None:
        self._keyed = hashlib.blake2s(key=key, digest_size=FRAME_MAC_SIZE)
        self._counter = count(1)

    def seal(self, frame: bytes) -> bytes:
        body = frame + _COUNTER.pack(next(self._counter))
        mac = self._keyed.copy()  # copying the keyed state skips hashing the key again
        mac.update(body)
        return body + mac.digest()


@dataclass(slots=True)
class DropCounts:
    """Frames a member dropped: no valid MAC, a counter already seen, or (keyed or
    not) bytes that are no well-formed frame of their kind."""

    forged: int = 0
    replayed: int = 0
    malformed: int = 0

    @property
    def total(self) -> int:
        return self.forged + self.replayed + self.malformed


class Verifier:
    """Checks each received frame; what it drops is counted in :attr:`dropped`."""

    def __init__(self, key: bytes, dropped: DropCounts | None = None) -> None:
        self._keyed = hashlib.blake2s(key=key, digest_size=FRAME_MAC_SIZE)
        #: sender member id -> (newest counter, bit k set: newest - k seen)
        self._windows: dict[int, tuple[int, int]] = {}
        self.dropped = DropCounts() if dropped is None else dropped

    def authentic(self, raw: bytes) -> bool:
        """Whether ``raw`` carries a valid MAC (no replay check, nothing counted)."""
        if len(raw) < HEADER_SIZE + FRAME_TRAILER_SIZE:
            return False
        mac = self._keyed.copy()
        mac.update(memoryview(raw)[:-FRAME_MAC_SIZE])
        return hmac.compare_digest(mac.digest(), raw[-FRAME_MAC_SIZE:])

    def open(self, raw: bytes) -> bytes | None:
        """``raw`` without its trailer, or None (counted) if it is forged or replayed."""
        if not self.authentic(raw):
            self.dropped.forged += 1
            return None
        (sender,) = _SENDER.unpack_from(raw, SENDER_OFFSET)
        (counter,) = _COUNTER.unpack_from(raw, len(raw) - FRAME_TRAILER_SIZE)
        if not self._fresh(sender, counter):
            self.dropped.replayed += 1
            return None
        return raw[:-FRAME_TRAILER_SIZE]

    def _fresh(self, sender: int, counter: int) -> bool:
        windows = self._windows
        state = windows.get(sender)
        if state is None:
            if len(windows) >= MAX_SENDERS:
                del windows[next(iter(windows))]
            windows[sender] = (counter, 1)
            return True
        newest, seen = state
        if counter > newest:
            shift = counter - newest
            seen = ((seen << shift) | 1) & _WINDOW_MASK if shift < REPLAY_WINDOW else 1
            windows[sender] = (counter, seen)
            return True
        behind = newest - counter
        if behind >= REPLAY_WINDOW or seen >> behind & 1:
            return False
        windows[sender] = (newest, seen | 1 << behind)
        return True
