"""A bus member's plumbing: its socket, its membership, its outgoing frames.

Both a node and a host are stations. The owner calls :meth:`Station.receive`
in its loop (it blocks at most the poll interval), handles the data frames it
returns, and calls :meth:`Station.service` whenever :meth:`Station.next_deadline`
has passed; bus-management frames never reach the owner, their effects arrive
as :meth:`Station.changes`.
"""

from __future__ import annotations

import heapq
import math
import os
import re
import secrets
import struct
import time
from collections.abc import Callable, Iterator
from itertools import count

from fw1394.engine.faults import FaultConfig, FaultInjector
from fw1394.packets import Speed
from fw1394.packets.frame import FRAME_TRAILER_SIZE
from fw1394.transport.media.choice import open_medium
from fw1394.transport.media.idle import IdleStrategy, default_idle
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Change, Membership, Role, Timing
from fw1394.transport.sansio.seal import DropCounts, Sealer, Verifier
from fw1394.transport.sansio.wire import (
    BROADCAST_PHY,
    CONTROL_KINDS,
    HEADER,
    HEADER_SIZE,
    MAGIC,
    MAX_UDP_PAYLOAD,
    NO_BOARD,
    NO_PHY,
    VERSION,
    FrameError,
    FrameHeader,
    FrameKind,
    FrameTooLarge,
    MemberInfo,
)
from fw1394.transport.supervision import runtime
from fw1394.transport.supervision.bus_key import key_for
from fw1394.transport.supervision.procs import pid_namespace, process_alive

_FAULTED = frozenset({FrameKind.async_packet, FrameKind.ack})
#: Kinds :class:`Membership` takes; only PHY packets of them also reach the owner.
_MANAGED = frozenset({*CONTROL_KINDS, FrameKind.phy_packet})
_PHY_PACKET = int(FrameKind.phy_packet)
_LAST_PHY = BROADCAST_PHY - 1


def skipping(layout: struct.Struct, skipped: frozenset[int]) -> struct.Struct:
    """``layout`` with its fields at positions ``skipped`` read as pad bytes."""
    order = layout.format[0]
    out, position = order, 0
    for repeat, code in re.findall(r"(\d*)([a-zA-Z?])", layout.format[1:]):
        if code in "xsp":  # padding (no field) and byte strings (one field) stay as they are
            out += repeat + code
            position += code != "x"
            continue
        for _ in range(int(repeat or 1)):
            out += f"{struct.calcsize(order + code)}x" if position in skipped else code
            position += 1
    return struct.Struct(out)


# The header of every received frame, unpacked straight into FrameHeader's field
# order (kind, tag, sender, generation, sender and destination physical IDs,
# speed, sequence), skipping magic, version and the reserved byte (fields 0, 1
# and 9 of the wire layout): the same bytes as :func:`parse_header` reads, for a
# third of its cost.
_FIELDS = skipping(HEADER, frozenset({0, 1, 9}))
_PREFIX = FrameHeader(0, 0, 0, 0, 0, 0).pack()[:3]  # magic and version
_new_header = tuple.__new__
assert _FIELDS.size == HEADER_SIZE
_MAX_PAYLOAD = MAX_UDP_PAYLOAD - HEADER_SIZE


def _unsealed(frame: bytes) -> bytes:
    return frame


class Station:
    """One member of the bus ``config.name``."""

    def __init__(
        self,
        config: BusConfig,
        *,
        rank: int | None = None,
        contender: bool = False,
        host: bool = False,
        board_id: int = NO_BOARD,
        timing: Timing | None = None,
        faults: FaultConfig | None = None,
        poll_interval: float = 0.005,
        drop_acks: bool = False,
        idle: IdleStrategy | None = None,
    ) -> None:
        self.config = config
        self._drop_acks = drop_acks
        self._tag = config.tag
        self.info = MemberInfo(
            member_id=secrets.randbits(32) or 1,
            rank=time.time_ns() if rank is None else rank,
            contender=contender,
            host=host,
            board_id=board_id,
            pid=os.getpid(),
            address=config.interface,
            pid_namespace=pid_namespace(),
        )
        self._member_id = self.info.member_id
        #: How this member waits for frames (``FW1394_IDLE`` unless given).
        self.idle = default_idle() if idle is None else idle
        self.medium = open_medium(config, poll_interval, self.idle)
        # A keyed bus: every datagram out is sealed (each copy on its own), every
        # one in verified; docs/virtual-bus.md, "Faults and threats".
        key = key_for(config)
        #: What this member dropped; forgeries and replays only on a keyed bus.
        self.drops = DropCounts()
        self._verifier = None if key is None else Verifier(key, self.drops)
        # A received frame in: the data frame for the owner, or None.
        self._take: Callable[[bytes], tuple[FrameHeader, bytes] | None] = (
            self.take_opened if key is None else self._open_and_take
        )
        # One sealer, one counter, whichever way a frame leaves.
        self._seal: Callable[[bytes], bytes] = _unsealed if key is None else Sealer(key).seal
        self._put = self.medium.send if key is None else self._sealed_sender(self._seal)
        self.trailer_size = 0 if key is None else FRAME_TRAILER_SIZE
        self._max_payload = _MAX_PAYLOAD - self.trailer_size
        self.medium.filter_as_member(self.info.member_id, None, drop_acks)
        self.membership = Membership(self.info, time.monotonic(), timing)
        self._filtered_phy: int | None = None
        #: The generation whose members on this host the medium was last told of.
        self._shared_in = -1
        self._sequence = count(1)
        self._injector = FaultInjector(faults) if faults and faults.active else None
        self._delayed: list[tuple[float, int, bytes]] = []
        #: When the earliest delayed frame is due: owners call :meth:`service` by then
        #: (a plain attribute, read on every turn of their loops).
        self.wake_by = math.inf
        self._last_pid_check = 0.0
        self._record = runtime.MemberFile(config.name, self.info, self.drops, keyed=key is not None)

    # -- state ------------------------------------------------------------------------
    @property
    def generation(self) -> int:
        return self.membership.generation

    @property
    def phy_id(self) -> int | None:
        return self.membership.phy_id

    @property
    def member_id(self) -> int:
        return self.info.member_id

    @property
    def faults(self) -> FaultInjector | None:
        return self._injector

    @property
    def dropped(self) -> DropCounts | None:
        """Frames dropped for want of a valid MAC, or as replays; None: insecure bus.

        Malformed frames are counted on every bus, in :attr:`drops`."""
        return None if self._verifier is None else self.drops

    def _sealed_sender(self, seal: Callable[[bytes], bytes]) -> Callable[[bytes], None]:
        send = self.medium.send
        return lambda frame: send(seal(frame))

    def changes(self) -> list[Change]:
        return self.membership.changes()

    def next_deadline(self) -> float:
        due = self.membership.next_deadline()
        if self._delayed:
            due = min(due, self._delayed[0][0])
        return due

    # -- sending ----------------------------------------------------------------------
    def send(self, kind: int, destination: int, payload: bytes, speed: int = Speed.S400) -> int:
        """Put a frame on the bus; its sequence number (acks refer to it).

        Raises :class:`FrameTooLarge` (and sends nothing) for a payload no datagram
        can carry.
        """
        if len(payload) > self._max_payload:
            raise FrameTooLarge(HEADER_SIZE + len(payload) + self.trailer_size)
        sequence = next(self._sequence) & 0xFFFFFFFF
        membership = self.membership
        phy = membership.phy_id
        # Packed in place rather than through FrameHeader: this runs for every packet.
        frame = (
            HEADER.pack(
                MAGIC,
                VERSION,
                kind,
                self._tag,
                self._member_id,
                membership.generation & 0xFFFFFFFF,
                NO_PHY if phy is None else phy,
                destination,
                speed,
                0,
                sequence,
            )
            + payload
        )
        if self._injector is None or kind not in _FAULTED:
            self._put(frame)
            return sequence
        # Sealed once: a copy the medium makes (duplicate, delay) is the same datagram,
        # so a keyed bus drops a second copy as a replay, as it would on a real network.
        frame, now = self._seal(frame), time.monotonic()
        for when in self._injector.send_times(now):
            if when <= now:
                self.medium.send(frame)
            else:
                heapq.heappush(self._delayed, (when, sequence, frame))
                self.wake_by = min(self.wake_by, when)
        return sequence

    # -- receiving --------------------------------------------------------------------
    def catch_up(self) -> Iterator[tuple[FrameHeader, bytes]]:
        """Every frame queued while the owner was away, taken without waiting.

        Each data frame is handed over before the frames behind it are taken, so
        that a bus reset queued after the answers to a transaction takes effect
        only after the owner has taken those answers, as in :meth:`receive`.
        """
        while (raw := self.medium.receive_queued()) is not None:
            frame = self._take(raw)
            if frame is not None:
                yield frame

    def receive(self) -> tuple[FrameHeader, bytes] | None:
        """The next data frame (async packet, ack, PHY packet), or None on a quiet poll."""
        raw = self.medium.receive()
        return None if raw is None else self._take(raw)

    def open(self, raw: bytes) -> bytes | None:
        """A datagram from :attr:`medium` with its MAC checked and cut off (as it came,
        on an insecure bus); None: forged or replayed, counted, never to be seen."""
        return raw if self._verifier is None else self._verifier.open(raw)

    def _open_and_take(self, raw: bytes) -> tuple[FrameHeader, bytes] | None:
        assert self._verifier is not None
        opened = self._verifier.open(raw)
        if opened is None:
            return None  # forged or replayed: counted, never seen
        return self.take_opened(opened)

    def take_opened(self, raw: bytes) -> tuple[FrameHeader, bytes] | None:
        """A received frame, its MAC (on a keyed bus) already checked and cut off:
        the data frame to hand the owner, or None (bus management, line noise)."""
        if raw[:3] != _PREFIX or len(raw) < HEADER_SIZE:
            return None  # not ours: nothing on a real bus answers line noise
        header: FrameHeader = _new_header(FrameHeader, _FIELDS.unpack_from(raw))
        payload = raw[HEADER_SIZE:]
        if header.kind in _MANAGED:
            try:
                self.membership.receive(header, payload, time.monotonic())
            except FrameError:
                # A short table, join or refusal: whoever sent it (a member with a
                # bug, or anyone on an insecure bus) must not end this member.
                self.drops.malformed += 1
                return None
            self._flush_control()
            if header.kind != _PHY_PACKET:
                return None
        if header.sender_phy > _LAST_PHY:
            # No member sends data before it has a node's physical ID: answering
            # or acking it would address nobody.
            self.drops.malformed += 1
            return None
        return header, payload

    def service(self, now: float | None = None) -> None:
        """Timers: heartbeats, beacons, leases, delayed frames."""
        now = time.monotonic() if now is None else now
        while self._delayed and self._delayed[0][0] <= now:
            self.medium.send(heapq.heappop(self._delayed)[2])
        self.wake_by = self._delayed[0][0] if self._delayed else math.inf
        membership = self.membership
        # Only the coordinator acts on a death, so only it pays for looking.
        coordinating = membership.role is Role.coordinator
        if coordinating and now - self._last_pid_check >= membership.timing.heartbeat:
            self._last_pid_check = now
            self._check_local_processes(now)
        membership.tick(now)
        self._flush_control()
        self._record.update(now)

    def _check_local_processes(self, now: float) -> None:
        # Members on this host in this PID namespace: a dead process is noticed at
        # once instead of after its lease (a crash is then a prompt bus reset).
        me = self.info
        for member in self.membership.members:
            same_host = member.address == me.address and member.pid_namespace == me.pid_namespace
            if same_host and member.pid and not process_alive(member.pid):
                self.membership.mark_dead(member.member_id, now)

    def members_here(self) -> int:
        """Members of this bus on this host (in this PID namespace), this one included."""
        me = self.info
        return max(
            1,
            sum(
                m.address == me.address and m.pid_namespace == me.pid_namespace
                for m in self.membership.members
            ),
        )

    def _share_host(self) -> None:
        # How the medium waits depends on whether its members outnumber the CPUs
        # (fw1394.transport.media.idle); a stand-in medium in a test may not wait at all.
        share = getattr(self.medium, "share_host", None)
        if share is not None:
            share(self.members_here())

    def _flush_control(self) -> None:
        # The link takes its new address before its self-ID (among these frames)
        # goes out: a member that has seen every self-ID may address us at once,
        # and the kernel filters a datagram as it arrives, so one that came in
        # under the old filter would be lost (docs/virtual-bus.md, "ready").
        phy = self.membership.phy_id
        if phy != self._filtered_phy:
            self.medium.filter_as_member(self.info.member_id, phy, self._drop_acks)
            self._filtered_phy = phy
        if self.membership.generation != self._shared_in:
            self._shared_in = self.membership.generation
            self._share_host()
        for out in self.membership.outgoing():
            self.send(out.kind, out.destination, out.payload)

    def request_reset(self) -> None:
        self.membership.request_reset(time.monotonic())
        self._flush_control()

    def rejoin(self) -> None:
        """Leave the bus and join it again (one bus reset)."""
        self.membership.rejoin(time.monotonic())
        self._flush_control()

    def close(self) -> None:
        """Leave the bus (the others reset at once) and close the socket."""
        try:
            self.membership.leave()
            self._flush_control()
        finally:
            self.medium.close()
            self._record.remove()
