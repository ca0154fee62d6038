"""The shared-memory medium: every frame of the bus in one ring, in one file.

Members on one host reach each other without the kernel's network stack: the
bus is a file (mode 0600, the key file's trust), mapped by every member. A
writer appends each frame to the ring under an exclusive ``flock`` of the
file; every reader (member or tap) keeps its own cursor and reads the records
in ring order, so every member and every tap sees one bus order, as every PHY
of a cable repeats the same packets in the same order. Address recognition is
the reader's: a member takes only frames for its physical ID, broadcast (63)
or every member (0xFF), never its own, and a node never the acks of its
responses (:mod:`fw1394.transport.media.bpf` filters the same way in the kernel for
the UDP medium).

**Where.** ``/dev/shm/fw1394-UID/NAME/ring.NETNS`` (:func:`segment_path`),
the file and its directories this user's alone (0600 and 0700): whoever can
open it is a member, which is the bus key file's trust.

**Records.** The ring holds records at increasing byte *positions*; a record
lives at ``position mod RING_SIZE``, 8-byte aligned: a 24-byte header
(:data:`RECORD`: its position, the writer's clock in ns, the frame's length
and a CRC-32 of those and of the frame), then the frame. A record that would
not fit before the ring's end is preceded by a pad record (or by nothing when
less than a header is left) and starts the next lap at offset 0.

**Commit, and the memory-ordering argument.** A reader accepts the record at
its cursor only when the record's own position field equals the cursor and
its CRC matches the bytes it copied. Nothing else is trusted, so the
argument needs no ordering between the writer's stores at all (it holds on
x86-64's TSO and on aarch64's weaker model alike): a reader that sees some of a
record's stores but not others reads a stale position (the previous lap's) or
bytes that fail the CRC, and tries again later; the head counter is a hint for
writers and for lap detection only. A CRC-32 lets a torn read through with
probability 2^-32, the same order as a datagram's undetected corruption.

**Writers.** ``flock`` serialises writers and, being a system call, orders
their accesses to the head. The kernel releases the lock of a process that
dies, so a writer killed mid-frame leaves at most a record that never became
valid, which the next writer overwrites, or a complete one it did not count
in the head, which the next writer finds (its position is the head) and
counts; the bus goes on, and the membership's next reset deals with the dead
member as with any other.

**A holder that does not let go.** A writer stopped while it holds the lock
(SIGSTOP, a debugger, a machine that does not schedule it) is alive, so the
kernel keeps its lock and every other writer would wait for it. A waiter that
finds the holder stopped (``/proc``'s state ``T``), or the lock held for
:data:`HOLD_LIMIT`, *moves the bus*: under the segment's ``flock`` it makes a
fresh segment (a new incarnation, so a new lock and new doorbells), renames it
over the old one's path and marks the old one retired at its head, then rings
every sleeper. Every member that finds the mark reads the old ring up to that
head and follows to the new one (same slot settings, same doorbell socket,
reading from its start), so no frame written before the move is lost and the
bus order is kept. The stopped writer, resumed, finishes its record in the
retired ring, where nobody reads past the mark, and follows at its next lock:
a stale writer cannot touch the new segment. The membership then does what it
does on UDP: a member silent for a lease is dropped by a bus reset, and
rejoins with the next one. Measured on the development machine, an
uncontended ``flock``/``funlock`` pair costs 0.5-0.9 µs, a record written
and read about 2 µs of Python in all (``bench/bus.py --mechanisms``).

**Doorbells.** A member that has nothing to read and wants to sleep *arms*
its slot: under the lock it sets its byte in the armed table and reads the
head; if the head moved past its cursor it does not sleep. A writer, under
the same lock, publishes its record and then reads the armed table; every
armed member the frame is addressed to is disarmed and rung: a post of its
slot's POSIX semaphore when it waits in its own receive (a futex wake-up,
cheaper than a datagram's), or a datagram to its Unix socket in the abstract
namespace when its owner selects on :attr:`SharedMedium.sock`; both are
named after the segment's incarnation and the slot. The lock orders the two: either the writer's
record precedes the reader's look at the head, or the reader's arm precedes
the writer's look at the table, so no wake-up is lost, and an unaddressed
member is never woken. A member's slot is its own while its doorbell socket
exists: the kernel frees the name when the process dies, so the next member
to claim a slot may take a dead member's.
"""

from __future__ import annotations

import contextlib
import fcntl
import math
import mmap
import os
import secrets
import socket
import stat
import struct
import tempfile
import time
import zlib
from collections.abc import Callable, Iterator
from pathlib import Path

import posix_ipc
from construct import Bytes, Int32un, Int64un, Struct

from fw1394.packets.bitfields import struct_format
from fw1394.packets.frame import field_offsets
from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.transport.media.idle import (
    BLOCK,
    LONGEST_SLEEP,
    IdleStrategy,
    PollPermit,
    set_receive_timeout,
)
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import (
    CONTROL_KINDS,
    DESTINATION_OFFSET,
    EVERY_MEMBER,
    HEADER_PREFIX,
    HEADER_SIZE,
    KIND_OFFSET,
    SENDER_OFFSET,
    TAG_OFFSET,
    FrameKind,
)
from fw1394.transport.supervision.procs import process_alive, process_stopped

#: The segment's first bytes: what it is and its layout's version.
SEGMENT_MAGIC = b"fw1394 bus ring5"
SEGMENT = Struct(
    "magic" / Bytes(16),
    "head" / Int64un,  # the next record's position (a hint: see the module's text)
    "incarnation" / Int64un,  # random per segment: names its doorbells and its lock
    "owner" / Int32un,  # pid of the writer holding the lock, 0 while nobody does
    "recoveries" / Int32un,  # locks taken back from writers that died holding them
    "retired" / Int64un,  # 0 while in use; else 1 + the head when the bus moved on
)
#: Random bits of a segment's incarnation: positive even where read as a signed 64-bit value.
INCARNATION_BITS = 63  # not a node ID
RECORD = Struct(
    "position" / Int64un,
    "stamp" / Int64un,  # the writer's time.time_ns() when it took the lock
    "length" / Int32un,  # PAD: the rest of the lap is empty
    "crc" / Int32un,  # CRC-32 of the 20 bytes before it, then of the frame
)
# Native byte order, 8-byte aligned: struct then copies each field with one
# machine load or store (a big-endian field is written a byte at a time, and a
# reader could see half an old and half a new position). The segment never
# leaves the host.
_RECORD = struct.Struct("=" + struct_format(RECORD)[1:])
_HEAD = struct.Struct("=Q")
_OWNER = struct.Struct("=I")
_SEGMENT_AT = field_offsets(SEGMENT)
_HEAD_AT, _OWNER_AT = _SEGMENT_AT["head"], _SEGMENT_AT["owner"]
_RECOVERIES_AT = _SEGMENT_AT["recoveries"]
_RETIRED_AT = _SEGMENT_AT["retired"]
#: How long a writer waits for the lock before it looks whether its holder died.
LOCK_PATIENCE = 0.25
#: Looks at a held lock without an owner before it counts as dead: its holder
#: died between taking it and saying so, or is that slow (see ``_take_back``).
OWNERLESS_LOOKS = 8
#: Seconds a live writer may keep the lock before the bus moves on without it
#: (a record takes microseconds; a stopped holder is found sooner, by its state).
HOLD_LIMIT = 2.0
RECORD_SIZE = _RECORD.size
_CHECKED = RECORD_SIZE - 4  # the header bytes the CRC covers before the frame
#: Those bytes packed on their own (the record's fields but its CRC).
_CHECKED_FIELDS = struct.Struct(_RECORD.format[:-1])
assert _CHECKED_FIELDS.size == _CHECKED
PAD = 0xFFFF_FFFF
#: Room for slots: 63 members and their taps and tools, with spares.
SLOTS = 256
#: Per slot: member id (u32), physical ID (u8, NO_PHY none), mode (u8), drop acks (u8),
#: and how its member waits to be rung (u8).
_SLOT = struct.Struct(">IBBBB")
MODE_FREE, MODE_MEMBER, MODE_TAP = 0, 1, 2
#: A member blocked in its own receive waits on a semaphore (a futex: 3-4 us of CPU a
#: wake-up against 5 for a datagram); one whose owner selects on :attr:`SharedMedium.sock`
#: is rung with a datagram to that socket.
BELL_SEMAPHORE, BELL_SOCKET = 0, 1
_NO_PHY = 0xFF
_ARMED_AT = 64
_SLOTS_AT = _ARMED_AT + SLOTS
RING_OFFSET = 8192
#: Bytes of ring: about as many frames as the UDP medium's socket buffer holds.
RING_SIZE = 1 << 22
SEGMENT_SIZE = RING_OFFSET + RING_SIZE
#: The largest frame a record holds (a UDP datagram's payload, as on the UDP medium).
MAX_FRAME = 65_507
_ARMED = b"\x01"
#: A writer at the head overwrites at most this far ahead of it.
_LARGEST_RECORD = (RECORD_SIZE + MAX_FRAME + 7) & ~7
_ACK = int(FrameKind.ack)
_FIRST_CONTROL_KIND = min(CONTROL_KINDS)
_SENDER = slice(SENDER_OFFSET, SENDER_OFFSET + 4)
_TAG = slice(TAG_OFFSET, TAG_OFFSET + 4)
_PREFIX = slice(0, len(HEADER_PREFIX))
_crc = zlib.crc32
_time_ns = time.time_ns


def _network_namespace() -> int:
    # Loopback is per network namespace: buses of one name in two namespaces are
    # two buses, on this medium as on UDP.
    try:
        return os.stat("/proc/self/ns/net").st_ino
    except OSError:
        return 0


def segment_directory() -> Path:
    """This user's directory of bus rings: in ``/dev/shm`` (memory, never written
    back to a disk) where there is one.

    Not under the runtime root (``XDG_RUNTIME_DIR``): members that disagree about
    that still meet on one bus, as they do on UDP, where a bus is its name.
    """
    base = Path("/dev/shm")
    if not base.is_dir():
        base = Path(tempfile.gettempdir())
    return base / f"fw1394-{os.getuid()}"


def segment_path(config: BusConfig) -> Path:
    """Where the bus ``config.name`` of this network namespace keeps its ring."""
    return segment_directory() / config.name / f"ring.{_network_namespace()}"


def _private_directory(path: Path) -> None:
    # Made 0700 if missing; refused unless it is this user's own, not a link, and
    # closed to others: another user could have made it first in a shared /dev/shm.
    path.mkdir(mode=0o700, parents=True, exist_ok=True)
    status = path.lstat()
    if not stat.S_ISDIR(status.st_mode) or status.st_uid != os.getuid():
        raise PermissionError(f"{path} is not a directory of this user's")
    if stat.S_IMODE(status.st_mode) & 0o077:
        raise PermissionError(f"{path} is open to other users (mode {status.st_mode:o})")


@contextlib.contextmanager
def _exclusive(fd: int) -> Iterator[None]:
    """The segment file's ``flock``, for what is rare: creating, claiming, recovering."""
    fcntl.flock(fd, fcntl.LOCK_EX)
    try:
        yield
    finally:
        fcntl.flock(fd, fcntl.LOCK_UN)


def _align(size: int) -> int:
    return (size + 7) & ~7


def _fresh_header() -> bytes:
    """A new segment's header: an empty ring, no owner, a new incarnation."""
    return bytes(
        SEGMENT.build(
            {
                "magic": SEGMENT_MAGIC,
                "head": 0,
                "incarnation": secrets.randbits(INCARNATION_BITS),
                "owner": 0,
                "recoveries": 0,
                "retired": 0,
            }
        )
    )


class SharedMedium:
    """The bus as a ring in shared memory, with the same calls as the UDP medium.

    ``idle`` is how :meth:`receive` waits (:mod:`fw1394.transport.media.idle`).
    """

    def __init__(
        self, config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK
    ) -> None:
        self.config = config
        self.idle = idle
        self.path = segment_path(config)
        self._poll = poll_interval
        self._tag = config.tag.to_bytes(4, "big")
        #: Frames this reader lost because writers lapped it (a full receive buffer).
        self.overruns = 0
        #: Times this reader's doorbell woke it.
        self.wakeups = 0
        self._pid = os.getpid()
        #: Times this member followed the bus to a fresh segment (see the module's text).
        self.moves = 0
        self._slot_fields: tuple[int, int, int, bool] = (0, _NO_PHY, MODE_MEMBER, False)
        self._bell_kind = BELL_SEMAPHORE
        #: Other members' semaphore doorbells, opened as they are first rung.
        self._bells: dict[int, posix_ipc.Semaphore] = {}
        self._users = -1
        self._fd = fd = self._open_segment()
        self._bell: socket.socket | None = None
        try:
            self._mm = mmap.mmap(fd, SEGMENT_SIZE)
            self._incarnation = SEGMENT.parse(self._mm[: SEGMENT.sizeof()]).incarnation
            self._sem = self._open_lock()
            self._ringer = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
            self._ringer.setblocking(False)
            self._slot, self._bell = self._claim_slot()
            self._own_bell = self._open_bell(self._slot)
        except BaseException:
            if self._bell is not None:
                self._bell.close()
            os.close(fd)
            os.close(self._users)
            raise
        self._bell_timeout = -1.0
        self._cursor = self._head()
        self._stamp = 0
        # Address recognition: by destination byte, and the member id never heard.
        self._accepts = bytes(256)
        self._member = b""
        self._tap = False
        self._drop_acks = False
        #: The owner's timers: block no longer than ``deadline()`` (see :meth:`sleep_until`).
        self.deadline: Callable[[], float] | None = None
        self._last = -math.inf
        self._permit = PollPermit()
        self._selected = False
        self._yield: Callable[[], None] = getattr(os, "sched_yield", lambda: None)

    # -- the segment ------------------------------------------------------------------
    def _open_segment(self) -> int:
        _private_directory(self.path.parent.parent)
        _private_directory(self.path.parent)
        users = self.path.with_name(self.path.name + ".users")
        while True:
            # Held shared while this member uses the ring (a file of its own: flock
            # on the ring itself serialises the rare exclusive steps); the last to
            # leave, the one that can make it exclusive, removes both files.
            self._users = os.open(users, os.O_RDONLY | os.O_CREAT | os.O_CLOEXEC, 0o600)
            try:
                fcntl.flock(self._users, fcntl.LOCK_SH)
                try:
                    if os.stat(users).st_ino == os.fstat(self._users).st_ino:
                        return self._open_file()
                except FileNotFoundError:
                    pass
            except BaseException:
                os.close(self._users)
                raise
            os.close(self._users)  # removed by the last member meanwhile: again

    def _open_file(self) -> int:
        flags = os.O_RDWR | os.O_CREAT | os.O_CLOEXEC | os.O_NOFOLLOW
        fd = os.open(self.path, flags, 0o600)
        try:
            with _exclusive(fd):
                if os.fstat(fd).st_uid != os.getuid():
                    raise PermissionError(f"{self.path} belongs to another user")
                os.fchmod(fd, 0o600)
                if os.fstat(fd).st_size != SEGMENT_SIZE or os.pread(fd, 16, 0) != SEGMENT_MAGIC:
                    # New, or of another layout: start it afresh.
                    os.ftruncate(fd, 0)
                    os.ftruncate(fd, SEGMENT_SIZE)
                    os.pwrite(fd, _fresh_header(), 0)
        except BaseException:
            os.close(fd)
            raise
        return fd

    @property
    def _lock_name(self) -> str:
        return f"/fw1394-{os.getuid()}-{self._incarnation:x}"

    def _open_lock(self) -> posix_ipc.Semaphore:
        with _exclusive(self._fd):
            return posix_ipc.Semaphore(self._lock_name, posix_ipc.O_CREAT, 0o600, 1)

    def _lock(self) -> None:
        """Take the writers' lock: a POSIX semaphore, no system call while it is free."""
        if not self._take_free_lock():
            while not self._try_lock():
                self._follow()

    def _take_free_lock(self) -> bool:
        """The common case of :meth:`_lock`: the lock free and this segment the bus's.
        False: nothing taken, the general way must wait or follow."""
        try:
            self._sem.acquire(0)
        except posix_ipc.BusyError:
            return False
        mm = self._mm
        if _HEAD.unpack_from(mm, _RETIRED_AT)[0]:
            self._sem.release()
            return False
        _OWNER.pack_into(mm, _OWNER_AT, self._pid)
        return True

    def _try_lock(self) -> bool:
        """Take this segment's lock; False (not holding it) when the bus moved on."""
        sem = self._sem
        looks = 0
        started = time.monotonic()
        while True:
            recoveries = _OWNER.unpack_from(self._mm, _RECOVERIES_AT)[0]
            try:
                sem.acquire(LOCK_PATIENCE)
                break
            except posix_ipc.SignalError:
                continue  # its handler has run (or runs now); the wait goes on
            except posix_ipc.BusyError:
                looks += 1
                if self._retired() or self._take_back(
                    recoveries, looks, time.monotonic() - started
                ):
                    return False
        if self._retired():
            sem.release()
            return False
        _OWNER.pack_into(self._mm, _OWNER_AT, self._pid)
        return True

    def _unlock(self) -> None:
        _OWNER.pack_into(self._mm, _OWNER_AT, 0)
        self._sem.release()

    def _retired(self) -> int:
        """0 while this segment is the bus's; else 1 + the head it was retired at."""
        retired: int = _HEAD.unpack_from(self._mm, _RETIRED_AT)[0]
        return retired

    def _take_back(self, recoveries: int, looks: int, waited: float) -> bool:
        # The lock stayed taken for a whole patience. Its holder is dead if the pid
        # it wrote is gone, or if it wrote none for OWNERLESS_LOOKS patiences (it
        # died between taking the lock and writing its pid). Taking it back happens
        # under the segment's flock, once per death: a waiter that finds the count
        # of recoveries moved since it started waiting leaves it to whoever did it.
        # A holder that lives but does not let go is left behind: True, the bus moved.
        with _exclusive(self._fd):
            if self._retired():
                return True
            if _OWNER.unpack_from(self._mm, _RECOVERIES_AT)[0] != recoveries:
                return False
            if self._sem.value != 0:
                return False
            owner = _OWNER.unpack_from(self._mm, _OWNER_AT)[0]
            if owner == 0 and looks < OWNERLESS_LOOKS:
                return False
            if owner != 0 and process_alive(owner):
                if process_stopped(owner) or waited >= HOLD_LIMIT:
                    self._retire()
                    return True
                return False
            _OWNER.pack_into(self._mm, _RECOVERIES_AT, (recoveries + 1) & 0xFFFF_FFFF)
            _OWNER.pack_into(self._mm, _OWNER_AT, 0)
            self._sem.release()
            return False

    def _retire(self) -> None:
        """Put a fresh segment in this one's place and mark this one retired (its flock held)."""
        fresh = self.path.with_name(f"{self.path.name}.{secrets.token_hex(8)}")
        fd = os.open(fresh, os.O_RDWR | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        try:
            os.ftruncate(fd, SEGMENT_SIZE)
            os.pwrite(fd, _fresh_header(), 0)
        finally:
            os.close(fd)
        os.rename(fresh, self.path)
        _HEAD.pack_into(self._mm, _RETIRED_AT, self._head() + 1)
        with contextlib.suppress(posix_ipc.ExistentialError):
            posix_ipc.unlink_semaphore(self._lock_name)  # its holders keep it till they close
        armed = self._mm[_ARMED_AT:_SLOTS_AT]
        self._ring(
            [(slot, self._mm[_SLOTS_AT + 8 * slot + 7]) for slot in range(SLOTS) if armed[slot]]
        )
        self._unlink_bells()  # their sleepers hold them open till they follow

    def _follow(self) -> None:
        """Leave a retired segment for the one at its path, keeping this member's
        slot settings and doorbell socket (whoever selects on it need not know)."""
        old_fd, old_mm, old_sem, old_bells = self._fd, self._mm, self._sem, self._bells
        fd = self._open_file()
        try:
            mm = mmap.mmap(fd, SEGMENT_SIZE)
        except BaseException:
            os.close(fd)
            raise
        self._fd, self._mm = fd, mm
        self._incarnation = SEGMENT.parse(mm[: SEGMENT.sizeof()]).incarnation
        self._sem = self._open_lock()
        slot, bell = self._claim_slot()
        if self._bell is not None:
            os.dup2(bell.fileno(), self._bell.fileno())  # same socket object, new name
            bell.close()
            self._bell_timeout = -1.0
        else:
            self._bell = bell
        self._slot = slot
        old_bells[-1] = self._own_bell
        self._bells = {}
        self._own_bell = self._open_bell(slot)
        self._cursor = 0
        self.moves += 1
        for bell in old_bells.values():
            bell.close()
        old_sem.close()
        old_mm.close()
        os.close(old_fd)

    def _bell_name(self, slot: int) -> bytes:
        return b"\0fw1394-bell/%x/%d" % (self._incarnation, slot)

    def _semaphore_name(self, slot: int) -> str:
        return f"{self._lock_name}.{slot}"

    def _open_bell(self, slot: int) -> posix_ipc.Semaphore:
        """This member's semaphore doorbell in ``slot``, with no ring left in it by
        the slot's previous member."""
        bell = posix_ipc.Semaphore(self._semaphore_name(slot), posix_ipc.O_CREAT, 0o600, 0)
        with contextlib.suppress(posix_ipc.BusyError):
            while True:
                bell.acquire(0)
        return bell

    def _unlink_bells(self) -> None:
        for slot in range(SLOTS):
            with contextlib.suppress(posix_ipc.ExistentialError):
                posix_ipc.unlink_semaphore(self._semaphore_name(slot))

    def _ring(self, slots: list[tuple[int, int]]) -> None:
        """Ring each of ``slots`` (slot, how its member waits), disarmed under the lock."""
        for slot, kind in slots:
            if kind == BELL_SEMAPHORE:
                bell = self._bells.get(slot)
                if bell is None:
                    try:
                        bell = self._bells[slot] = posix_ipc.Semaphore(self._semaphore_name(slot))
                    except posix_ipc.ExistentialError:
                        continue  # gone with the bus's last member
                bell.release()
            else:
                # Gone (its slot is free again), or rung already and not yet awake.
                with contextlib.suppress(OSError):
                    self._ringer.sendto(b"", self._bell_name(slot))

    def _claim_slot(self) -> tuple[int, socket.socket]:
        bell = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)
        try:
            with _exclusive(self._fd):
                for slot in range(SLOTS):
                    try:
                        bell.bind(self._bell_name(slot))
                    except OSError:
                        continue  # a live member's
                    _SLOT.pack_into(
                        self._mm, _SLOTS_AT + 8 * slot, *self._slot_fields, self._bell_kind
                    )
                    self._mm[_ARMED_AT + slot] = 0
                    return slot, bell
        except BaseException:
            bell.close()
            raise
        bell.close()
        raise OSError(f"bus {self.config.name!r}: all {SLOTS} shared-memory slots are taken")

    def _head(self) -> int:
        head: int = _HEAD.unpack_from(self._mm, _HEAD_AT)[0]
        return head

    @property
    def head(self) -> int:
        """The ring position the next frame will be written at."""
        return self._head()

    @property
    def position(self) -> int:
        """The ring position this reader has read up to (:attr:`head` when caught up)."""
        return self._cursor

    # -- address recognition ----------------------------------------------------------
    def _set_slot(self, member_id: int, phy: int, mode: int, drop_acks: bool) -> None:
        self._slot_fields = (member_id, phy, mode, drop_acks)
        self._lock()
        try:
            _SLOT.pack_into(
                self._mm,
                _SLOTS_AT + 8 * self._slot,
                member_id,
                phy,
                mode,
                drop_acks,
                self._bell_kind,
            )
        finally:
            self._unlock()

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        """Hear what a node with ``phy_id`` (0-62) hears (None: bus-wide frames only)."""
        if phy_id is not None and not 0 <= phy_id < BROADCAST_PHY:
            raise ValueError(f"physical ID {phy_id} is not a node's (0-62)")
        accepts = bytearray(256)
        for destination in (EVERY_MEMBER, BROADCAST_PHY, phy_id):
            if destination is not None:
                accepts[destination] = 1
        self._accepts = bytes(accepts)
        self._member = member_id.to_bytes(4, "big")
        self._tap, self._drop_acks = False, drop_acks
        self._set_slot(member_id, _NO_PHY if phy_id is None else phy_id, MODE_MEMBER, drop_acks)

    def filter_as_tap(self) -> None:
        """Hear every frame of the bus, with the time its writer put it on."""
        self._tap = True
        self._set_slot(0, _NO_PHY, MODE_TAP, False)

    # -- writing ----------------------------------------------------------------------
    def send(self, frame: bytes) -> None:
        length = len(frame)
        if length > MAX_FRAME:
            return  # no datagram carries it either: lost, as on the wire
        if not self._take_free_lock():
            self._lock()
        mm = self._mm  # another one if the bus moved on while this member waited
        try:
            # Written out here rather than in helpers: a quadlet read puts three
            # frames on the bus, and a Python call costs as much as a field packed.
            head = _HEAD.unpack_from(mm, _HEAD_AT)[0]
            offset = head % RING_SIZE
            if _HEAD.unpack_from(mm, RING_OFFSET + offset)[0] == head:
                # Most likely a record a writer that died did not count: look closely.
                head = self._writable_head()
                offset = head % RING_SIZE
            before = head
            room = RING_SIZE - offset
            need = (RECORD_SIZE + length + 7) & ~7
            if room < need:
                if room >= RECORD_SIZE:
                    self._write_record(head, offset, b"", PAD)
                head += room
                offset = 0
            at = RING_OFFSET + offset
            stamp = _time_ns()
            mm[at + RECORD_SIZE : at + RECORD_SIZE + length] = frame
            crc = _crc(frame, _crc(_CHECKED_FIELDS.pack(head, stamp, length)))
            _RECORD.pack_into(mm, at, head, stamp, length, crc)
            _HEAD.pack_into(mm, _HEAD_AT, head + need)
            if self._cursor == before:
                self._cursor = head + need  # its own frame: no reader of it here
            ring = (
                ()
                if mm.find(_ARMED, _ARMED_AT, _SLOTS_AT) < 0
                else self._disarm_addressed(mm[_ARMED_AT:_SLOTS_AT], frame)
            )
        finally:
            _OWNER.pack_into(mm, _OWNER_AT, 0)
            self._sem.release()
        if ring:
            self._ring(ring)
        if self.idle.window and frame[KIND_OFFSET] < _FIRST_CONTROL_KIND:
            self._last = time.monotonic()  # the answer comes soon: be awake for it

    def _writable_head(self) -> int:
        # A writer that died between its record and the head left a valid record
        # at the head: it is on the bus (readers may have taken it), so count it.
        head = self._head()
        while (after := self._record_end(head)) is not None:
            head = after
        return head

    def _record_end(self, position: int) -> int | None:
        """Where the valid record at ``position`` ends (the next position), or None."""
        offset = position % RING_SIZE
        room = RING_SIZE - offset
        if room < RECORD_SIZE:
            return None
        at = RING_OFFSET + offset
        stored, _, length, crc = _RECORD.unpack_from(self._mm, at)
        if stored != position:
            return None
        size = 0 if length == PAD else length
        if size > room - RECORD_SIZE:
            return None
        body = self._mm[at + RECORD_SIZE : at + RECORD_SIZE + size]
        if _crc(body, _crc(self._mm[at : at + _CHECKED])) != crc:
            return None
        return position + (room if length == PAD else _align(RECORD_SIZE + length))

    def _write_record(self, position: int, offset: int, frame: bytes, length: int) -> None:
        at = RING_OFFSET + offset
        stamp = time.time_ns()
        mm = self._mm
        mm[at + RECORD_SIZE : at + RECORD_SIZE + len(frame)] = frame
        crc = _crc(frame, _crc(_CHECKED_FIELDS.pack(position, stamp, length)))
        _RECORD.pack_into(mm, at, position, stamp, length, crc)

    def _disarm_addressed(self, armed: bytes, frame: bytes) -> list[tuple[int, int]]:
        mm = self._mm
        destination = frame[DESTINATION_OFFSET] if len(frame) > DESTINATION_OFFSET else 0
        everyone = destination >= BROADCAST_PHY
        sender = int.from_bytes(frame[_SENDER], "big") if len(frame) >= HEADER_SIZE else 0
        is_ack = len(frame) > KIND_OFFSET and frame[KIND_OFFSET] == _ACK
        ring = []
        slot = armed.find(1)
        while slot >= 0:
            member, phy, mode, drop_acks, bell = _SLOT.unpack_from(mm, _SLOTS_AT + 8 * slot)
            if mode == MODE_TAP or (
                mode == MODE_MEMBER
                and (everyone or phy == destination)
                and member != sender
                and not (drop_acks and is_ack)
            ):
                mm[_ARMED_AT + slot] = 0
                ring.append((slot, bell))
            slot = armed.find(1, slot + 1)
        return ring

    # -- reading ----------------------------------------------------------------------
    def _next(self) -> bytes | None:
        """The next frame for this reader already on the ring, or None."""
        while True:
            mm = self._mm  # another one after the bus moved on
            cursor = self._cursor
            offset = cursor % RING_SIZE
            room = RING_SIZE - offset
            if room < RECORD_SIZE:
                self._cursor = cursor + room
                continue
            at = RING_OFFSET + offset
            position, stamp, length, crc = _RECORD.unpack_from(mm, at)
            if position != cursor:
                if self._stalled():
                    continue
                return None
            size = 0 if length == PAD else length
            if size > room - RECORD_SIZE:
                if self._stalled():
                    continue
                return None
            frame = mm[at + RECORD_SIZE : at + RECORD_SIZE + size]
            if _crc(frame, _crc(mm[at : at + _CHECKED])) != crc:
                if self._stalled():
                    continue
                return None
            if _HEAD.unpack_from(mm, _RETIRED_AT)[0] and cursor >= self._retired() - 1:
                self._follow()  # written after the bus moved on: a stale writer's
                continue
            if length == PAD:
                self._cursor = cursor + room
                continue
            self._cursor = cursor + ((RECORD_SIZE + length + 7) & ~7)
            # Address recognition (see filter_as_member), written out: it runs for
            # every frame of the bus.
            if (
                length >= HEADER_SIZE
                and frame[_PREFIX] == HEADER_PREFIX
                and frame[_TAG] == self._tag
                and (
                    self._tap
                    or (
                        self._accepts[frame[DESTINATION_OFFSET]] == 1
                        and frame[_SENDER] != self._member
                        and not (self._drop_acks and frame[KIND_OFFSET] == _ACK)
                    )
                )
            ):
                self._stamp = stamp
                return frame

    def _stalled(self) -> bool:
        """Nothing valid at the cursor: not written yet (or not all of it visible
        yet), unless the writers have gone a ring past this reader or the bus moved
        on to a fresh segment (True: read again)."""
        retired = self._retired()
        if retired and self._cursor >= retired - 1:
            self._follow()
            return True
        if self._head() - self._cursor > RING_SIZE - _LARGEST_RECORD:
            self._lapped()
            return True
        return False

    def _lapped(self) -> None:
        # Back to the first record of the writers' current lap, which starts at
        # offset 0 and is intact until they come round again: what is lost is at
        # most one ring's worth, as a full receive buffer loses.
        self.overruns += 1
        head = self._head()
        self._cursor = head - head % RING_SIZE

    def _arm(self) -> bool:
        """Ask to be rung for the next frame for this reader; False: one may be there."""
        index = _ARMED_AT + self._slot
        if not self._take_free_lock():
            self._lock()
        mm = self._mm
        try:
            mm[index] = 1
            quiet: bool = _HEAD.unpack_from(mm, _HEAD_AT)[0] <= self._cursor
            if not quiet:
                mm[index] = 0
        finally:
            _OWNER.pack_into(mm, _OWNER_AT, 0)
            self._sem.release()
        return quiet

    def _sleep(self, seconds: float) -> bool:
        """Armed: wait for the doorbell at most ``seconds``; whether it rang."""
        assert self._bell is not None
        if self._bell_kind == BELL_SEMAPHORE:
            try:
                self._own_bell.acquire(seconds)
                rang = True
                self.wakeups += 1
            except (posix_ipc.BusyError, posix_ipc.SignalError):
                rang = False  # a signal: its handler runs as this returns, as after recv
            self._mm[_ARMED_AT + self._slot] = 0  # a ring that comes now wakes it once more
            return rang
        # The socket's timeout is a system call to change: changed only when it must
        # shrink by more than a poll interval or could double, as the UDP medium does.
        current = self._bell_timeout
        if seconds < current - self._poll or seconds > 2 * current:
            set_receive_timeout(self._bell, seconds)
            self._bell_timeout = seconds
        try:
            self._bell.recv(16)
            rang = True
            self.wakeups += 1
        except (BlockingIOError, InterruptedError):
            rang = False
        self._mm[_ARMED_AT + self._slot] = 0  # a bell that comes now only wakes it once more
        return rang

    def _wait(self, limit: float) -> bytes | None:
        """The next frame, waiting as the idle strategy says, or None at ``limit``."""
        clock = time.monotonic
        window = self.idle.window
        if window:
            now = clock()
            until = min(limit, self._last + window)
            if window != math.inf:
                until = self._permit.until(now, until)
            pause, take = self._yield, self._next
            while now < until:
                frame = take()
                if frame is not None:
                    self._last = clock()
                    return frame
                pause()
                now = clock()
            if window == math.inf:
                return None
        while True:
            if self._arm():
                left = limit - clock()
                if left <= 0:
                    self._mm[_ARMED_AT + self._slot] = 0
                    return None
                self._sleep(max(left, 1e-6))
            frame = self._next()
            if frame is not None:
                if window and frame[KIND_OFFSET] < _FIRST_CONTROL_KIND:
                    self._last = clock()
                return frame
            if clock() >= limit:
                return None

    def _limit(self) -> float:
        now = time.monotonic()
        if self.deadline is None:
            return now + self._poll
        return now + min(max(self.deadline() - now, self._poll), LONGEST_SLEEP)

    def receive(self) -> bytes | None:
        """The next frame, or None when the poll interval passes without one."""
        frame = self._next()
        if self._selected:
            # Whoever selects waits in select: readiness can be stale (the frames
            # that rang were for others), and a wait here would starve its sockets.
            self._ready_for_select()
            return frame
        if frame is None:
            frame = self._wait(self._limit())
        elif self.idle.window and frame[KIND_OFFSET] < _FIRST_CONTROL_KIND:
            self._last = time.monotonic()
        return frame

    def receive_queued(self) -> bytes | None:
        """The next frame already on the ring, or None at once if there is none.

        After :attr:`sock` was asked for, a None also arms the doorbell, so that
        the socket becomes readable when the next frame for this reader comes.
        """
        while True:
            frame = self._next()
            if frame is not None or not self._selected:
                return frame
            self._drain_bell()
            if self._arm():
                return None

    def receive_stamped(self, wait: bool = True) -> tuple[bytes, int] | None:
        """The next frame and when its writer put it on the ring (ns since the epoch).

        ``wait`` False: only a frame already there, None at once if there is none.
        """
        frame = self._next()
        if frame is None and wait:
            frame = self._wait(self._limit())
        return None if frame is None else (frame, self._stamp)

    def share_host(self, members: int) -> None:
        """This bus has ``members`` members on this host: more than CPUs and an
        adaptive member never polls (:mod:`fw1394.transport.media.idle`)."""
        self._permit.share_host(members)

    def sleep_until(self, deadline: Callable[[], float]) -> None:
        """Block, when nothing comes, until ``deadline()`` (monotonic) rather than
        for one poll interval (at most :data:`~fw1394.transport.media.idle.LONGEST_SLEEP`)."""
        self.deadline = deadline

    @property
    def sock(self) -> socket.socket:
        """A socket readable when a frame for this reader may be there, for ``select``.

        Whoever selects on it takes frames with :meth:`receive_queued` until None
        (or with :meth:`receive`, one per readable event).
        """
        assert self._bell is not None
        if not self._selected:
            self._selected = True
            # Rung on the socket from now on; a ring already on its way to the
            # semaphore is made good by the look under the lock that follows.
            self._bell_kind = BELL_SOCKET
            self._set_slot(*self._slot_fields)
            self._ready_for_select()
        return self._bell

    def _ready_for_select(self) -> None:
        # Armed when nothing is left to read, else rung by this reader itself: either
        # way the socket is readable whenever a frame may be waiting.
        self._drain_bell()
        if not self._arm():
            self._ringer.sendto(b"", self._bell_name(self._slot))

    def _drain_bell(self) -> None:
        assert self._bell is not None
        while True:
            try:
                self._bell.recv(16, socket.MSG_DONTWAIT)
            except (BlockingIOError, InterruptedError):
                return

    def close(self) -> None:
        if self._mm.closed:
            return
        try:
            self._set_slot(0, _NO_PHY, MODE_FREE, False)
            self._mm[_ARMED_AT + self._slot] = 0
            self._mm.close()
        finally:
            if self._bell is not None:
                self._bell.close()
            self._ringer.close()
            for bell in (*self._bells.values(), self._own_bell):
                bell.close()
            self._sem.close()
            self._leave_segment()

    def _leave_segment(self) -> None:
        users = self._users
        try:
            os.close(self._fd)
            fcntl.flock(users, fcntl.LOCK_UN)
            try:
                fcntl.flock(users, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except BlockingIOError:
                return  # others still use it
            # The last one: a member opening the bus now finds the files gone once
            # it holds them shared, and starts afresh.
            for path in (self.path, self.path.with_name(self.path.name + ".users")):
                with contextlib.suppress(FileNotFoundError):
                    path.unlink()
            with contextlib.suppress(posix_ipc.ExistentialError):
                posix_ipc.unlink_semaphore(self._lock_name)
            self._unlink_bells()
            with contextlib.suppress(OSError):
                self.path.parent.rmdir()  # unless another namespace's ring is there
        finally:
            os.close(users)
