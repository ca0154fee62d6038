"""Only members speak: every frame of a keyed bus ends with a counter and a keyed MAC.

A bus brought up by ``fw1394 bus up`` has a secret key (32 random bytes in its
runtime directory, mode 0600). Every member appends the trailer of
:data:`fw1394.packets.frame.FRAME_TRAILER` to each datagram it sends: a
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
import os
import struct
from dataclasses import dataclass
from itertools import count
from pathlib import Path

from fw1394.errors import UsageError
from fw1394.packets.frame import (
    FRAME_COUNTER_FORMAT,
    FRAME_HEADER_SPANS,
    FRAME_MAC_SIZE,
    FRAME_TRAILER_SIZE,
)
from fw1394.transport.config import BusConfig
from fw1394.transport.runtime import KEY_FILE, bus_dir
from fw1394.transport.wire import HEADER_SIZE, SENDER_OFFSET

KEY_SIZE = 32
#: The key of the bus a process joins, in hex (members on other hosts).
KEY_ENV = "FW1394_BUS_KEY"
#: A file holding that key (what ``bus up`` passes to the nodes it starts).
KEY_FILE_ENV = "FW1394_BUS_KEY_FILE"
#: Counters seen per sender: a frame this far behind the newest is a replay.
REPLAY_WINDOW = 64
#: Senders remembered; the oldest is forgotten beyond this (a MAC'd frame is needed
#: to make an entry, so only members can fill it).
MAX_SENDERS = 4096
#: The sender field of the frame header, as wide as the layout makes it.
_SENDER = struct.Struct(">" + {2: "H", 4: "I"}[FRAME_HEADER_SPANS["sender"][1]])
_COUNTER = FRAME_COUNTER_FORMAT
_WINDOW_MASK = (1 << REPLAY_WINDOW) - 1


class BusKeyError(UsageError):
    """A key file or variable that does not hold a usable bus key."""


def new_key() -> bytes:
    return os.urandom(KEY_SIZE)


def write_key(path: Path, key: bytes) -> None:
    """Write ``key`` (hex) to a new file only its owner can read.

    The directories above must be this user's and not writable by others (the
    runtime root under /tmp has a name anyone can guess and create first); the
    file is made anew, never through a link someone left there.
    """
    for directory in (path.parent, path.parent.parent):
        info = directory.lstat()
        if info.st_uid != os.getuid() or info.st_mode & 0o022:
            raise BusKeyError(f"{directory}: not a private directory of this user")
    path.unlink(missing_ok=True)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW
    with os.fdopen(os.open(path, flags, 0o600), "w") as out:
        out.write(key.hex() + "\n")


def parse_key(text: str, where: str) -> bytes:
    try:
        key = bytes.fromhex(text.strip())
    except ValueError:
        raise BusKeyError(f"{where}: not a hex bus key") from None
    if not 16 <= len(key) <= KEY_SIZE:
        raise BusKeyError(f"{where}: a bus key has 16 to {KEY_SIZE} bytes, not {len(key)}")
    return key


def read_key(path: Path) -> bytes:
    """The key in ``path``; refused if others than its owner may read it."""
    info = path.stat()
    if info.st_mode & 0o077 or info.st_uid != os.getuid():
        raise BusKeyError(f"{path}: a bus key must be this user's, readable by them only (600)")
    return parse_key(path.read_text(), str(path))


def key_for(config: BusConfig) -> bytes | None:
    """The key of ``config``'s bus: its own, else :func:`find_key`; None: insecure.

    ``BusConfig(key=b"")`` is a member that stays insecure whatever it finds.
    """
    if config.key is not None:
        return config.key or None
    return find_key(bus_dir(config.name) / KEY_FILE)


def find_key(key_file: Path | None) -> bytes | None:
    """The bus key this process uses: ``$FW1394_BUS_KEY``, ``$FW1394_BUS_KEY_FILE``,
    else ``key_file`` (the bus's runtime directory) if it exists; None: insecure."""
    if text := os.environ.get(KEY_ENV):
        return parse_key(text, KEY_ENV)
    if named := os.environ.get(KEY_FILE_ENV):
        return read_key(Path(named))
    if key_file is not None and key_file.exists():
        return read_key(key_file)
    return None


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
