"""Who is on the bus, and bus resets: a sans-IO state machine every member runs.

One member coordinates: the one with physical ID 0, i.e. the lowest sort key
(see :class:`~fw1394.transport.sansio.wire.MemberInfo`). It beacons, collects
heartbeats, admits joiners, notices leases running out and leaving members,
and then starts a bus reset: a ``bus_reset`` frame listing the members of the
new generation in physical-ID order, after which every listed member sends its
self-ID packet. Its beacons carry the member table.

Failure of the coordinator is covered by a fixed succession: the member with
physical ID k takes over after k leases without a beacon. Two coordinators
that hear each other (two halves of a bus that meet, or simultaneous starts)
settle it by sort key: the higher one yields and joins the lower one.

Nothing here touches a socket or a clock: frames come in through
:meth:`Membership.receive`, time through ``now``, and what to send leaves
through :meth:`Membership.outgoing`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import StrEnum

from fw1394.transport.sansio.selfid import is_self_id, self_id_bytes
from fw1394.transport.sansio.wire import (
    EVERY_MEMBER,
    MAX_MEMBERS,
    FrameError,
    FrameHeader,
    FrameKind,
    MemberInfo,
    pack_join,
    pack_refusal,
    pack_table,
    parse_join,
    parse_refusal,
    parse_table,
)

SortKey = tuple[bool, int, int]
#: Requests that concern the generation they were sent in: one from an earlier
#: generation is out of date (and on a keyed bus, where nobody can forge a frame
#: of this generation, the only way to replay one).
_OF_THIS_GENERATION = frozenset({FrameKind.reset_request, FrameKind.leave})
#: Generations beyond this are no bus's (a reset a millisecond would take 24 days
#: to get there): taken in, one would make the next reset's number wrap past the
#: frame header's 32 bits, and every member would ignore it as stale.
MAX_GENERATION = 0x7FFFFFFF
_TABLES = frozenset({FrameKind.beacon, FrameKind.bus_reset})


@dataclass(frozen=True, slots=True)
class Timing:
    """Periods of bus management, in seconds."""

    heartbeat: float = 0.1  # member heartbeats and coordinator beacons
    lease: float = 1.0  # silence after which a member or the coordinator is gone
    join_retry: float = 0.05
    settle: float = 0.002  # joins and leaves within this time share one reset
    self_id_timeout: float = 1.0  # a self-ID phase not complete by then is repeated
    #: How long a member that was never on the bus listens for a coordinator before
    #: it starts a bus of its own; None: a lease, so that a coordinator stopped for
    #: less than that is not replaced. 0 suits only the first node of a bus known
    #: to be new (``bus up`` knows); a member that rejoins always waits a lease.
    found_after: float | None = None


class Role(StrEnum):
    joining = "joining"
    member = "member"
    coordinator = "coordinator"


@dataclass(frozen=True, slots=True)
class Outgoing:
    kind: FrameKind
    destination: int
    payload: bytes = b""


@dataclass(frozen=True, slots=True)
class BusReset:
    """This member is in a new generation with ``phy_id`` among ``members``."""

    generation: int
    phy_id: int
    members: tuple[MemberInfo, ...]
    initiator: int


@dataclass(frozen=True, slots=True)
class Excluded:
    """A reset left this member out (it had gone silent too long); it is rejoining."""

    generation: int


@dataclass(frozen=True, slots=True)
class Refused:
    """The coordinator turned this member away."""

    reason: str


Change = BusReset | Excluded | Refused


@dataclass(slots=True)
class _CoordinatorState:
    last_heard: dict[int, float] = field(default_factory=dict)
    joins: dict[int, MemberInfo] = field(default_factory=dict)
    leaves: set[int] = field(default_factory=set)
    reset_due: float | None = None
    initiator: int = 0
    last_beacon: float = -math.inf


class Membership:
    """One member's view of the bus."""

    def __init__(self, me: MemberInfo, now: float, timing: Timing | None = None) -> None:
        self.me = me
        self.timing = timing or Timing()
        self.role = Role.joining
        self.generation = 0
        self.members: tuple[MemberInfo, ...] = ()
        self.phy_id: int | None = None
        self.self_ids: dict[int, bytes] = {}
        self._highest_generation = 0
        self._coordinator = 0  # member id of the coordinator followed
        # member id -> (sort key, last time heard) of coordinators beaconing
        self._coordinators: dict[int, tuple[SortKey, float]] = {}
        self._silence_since = now  # last beacon of the followed coordinator
        #: Silence before a joining member starts a bus of its own.
        found_after = self.timing.found_after
        self._listen = self.timing.lease if found_after is None else found_after
        self._last_join = -math.inf
        self._last_heartbeat = -math.inf
        self._reset_time = now
        #: When :meth:`tick` last ran: a longer gap means this process was not running.
        self._awake_at = now
        self._boss = _CoordinatorState()
        self._outgoing: list[Outgoing] = []
        self._changes: list[Change] = []

    # -- what the station drains ----------------------------------------------------
    def outgoing(self) -> list[Outgoing]:
        out, self._outgoing = self._outgoing, []
        return out

    def changes(self) -> list[Change]:
        out, self._changes = self._changes, []
        return out

    @property
    def ready(self) -> bool:
        """In a generation whose self-ID phase is complete."""
        return self.phy_id is not None and len(self.self_ids) >= len(self.members)

    def next_deadline(self) -> float:
        t = self.timing
        if self.role is Role.joining:
            return min(self._last_join + t.join_retry, self._silence_since + self._listen)
        due = self._last_heartbeat + t.heartbeat
        if self.role is Role.coordinator:
            due = min(due, self._boss.last_beacon + t.heartbeat)
            if self._boss.reset_due is not None:
                due = min(due, self._boss.reset_due)
        return due

    # -- input ------------------------------------------------------------------------
    def request_reset(self, now: float) -> None:
        """Ask for a bus reset (as a ``reset_request`` frame would)."""
        if self.role is Role.coordinator:
            self._schedule_reset(now, self.me.member_id)
        else:
            self._send(FrameKind.reset_request, EVERY_MEMBER)

    def leave(self) -> None:
        self._send(FrameKind.leave, EVERY_MEMBER)

    def rejoin(self, now: float) -> None:
        """Leave and join again at once.

        The coordinator makes one reset of both, or two when its last reset was so
        recent that it takes the join for one sent before that reset.
        """
        if self.role is not Role.joining:
            self.leave()
            self._rejoin(now)

    def receive(self, header: FrameHeader, payload: bytes, now: float) -> None:
        """A frame from another member (any kind; non-management kinds are ignored).

        Raises :class:`FrameError` (and changes nothing) for a frame that cannot be
        one of a working member: a short table, join or refusal, or a generation no
        bus reaches.
        """
        kind = header.kind
        if header.generation > MAX_GENERATION:
            raise FrameError(f"generation {header.generation} is beyond any bus's")
        # Parsed before anything changes: a frame that does not parse changes nothing.
        table = parse_table(payload) if kind in _TABLES else None
        join = parse_join(payload) if kind == FrameKind.join else None
        refusal = parse_refusal(payload) if kind == FrameKind.refused else None
        if kind in (FrameKind.join, FrameKind.bus_reset):
            self._highest_generation = max(self._highest_generation, header.generation)
        if kind == FrameKind.phy_packet:
            this_generation = header.generation == self.generation
            if this_generation and header.sender_phy < len(self.members) and is_self_id(payload):
                self.self_ids[header.sender_phy] = payload
            return
        if kind in _OF_THIS_GENERATION and header.generation < self.generation:
            return  # the reset since has done what it asked for; or a replay
        heard = self._boss.last_heard
        if self.role is Role.coordinator and header.sender in heard:
            heard[header.sender] = now  # members only: anyone else would grow it unbounded
        if table is not None and kind == FrameKind.beacon:
            self._on_beacon(header, table[1], now)
        elif table is not None:
            self._on_reset(header, table, now)
        elif join is not None:
            self._on_join(join, now)
        elif kind == FrameKind.leave:
            self._on_leave(header, now)
        elif kind == FrameKind.reset_request and self.role is Role.coordinator:
            self._schedule_reset(now, header.sender)
        elif refusal is not None and refusal[0] == self.me.member_id:
            self._changes.append(Refused(refusal[1]))

    def _on_beacon(self, header: FrameHeader, table: tuple[MemberInfo, ...], now: float) -> None:
        entry = next((m for m in table if m.member_id == header.sender), None)
        if entry is None:
            return
        self._coordinators[header.sender] = (entry.sort_key, now)
        if header.sender == self._coordinator and self.role is Role.member:
            self._silence_since = now
            listed = any(m.member_id == self.me.member_id for m in table)
            if header.generation != self.generation or not listed:
                self._rejoin(now)  # we missed a reset: ask to be taken in again
            return
        best = self._best_coordinator(now)
        if self.role is Role.joining:
            self._silence_since = now
            self._listen = self.timing.lease  # a bus is there: join it
        elif best != self._coordinator and best is not None:
            # A coordinator with a lower key is around: yield to it.
            self._rejoin(now)

    def _best_coordinator(self, now: float) -> int | None:
        live = {
            member_id: key
            for member_id, (key, heard) in self._coordinators.items()
            if now - heard <= self.timing.lease
        }
        if self.role is Role.coordinator:
            live[self.me.member_id] = self.me.sort_key
        elif self.role is Role.member and self.members:
            # The coordinator we follow counts even before its first beacon arrives.
            live[self.members[0].member_id] = self.members[0].sort_key
        return min(live, key=live.__getitem__) if live else None

    def _on_reset(
        self, header: FrameHeader, table: tuple[int, tuple[MemberInfo, ...]], now: float
    ) -> None:
        if header.generation <= self.generation:
            return  # stale, or a copy of a reset already taken part in
        if self.role is Role.coordinator and header.sender != self.me.member_id:
            known = self._coordinators.get(header.sender)
            theirs = known[0] if known else None
            if theirs is not None and theirs > self.me.sort_key:
                return  # a coordinator that must yield to us; it will hear our beacon
        initiator, members = table
        self._enter(header.generation, members, initiator, now)

    def _enter(
        self, generation: int, members: tuple[MemberInfo, ...], initiator: int, now: float
    ) -> None:
        self._highest_generation = max(self._highest_generation, generation)
        self.generation = generation
        ids = [m.member_id for m in members]
        if self.me.member_id not in ids:
            if self.role is not Role.joining:
                self._changes.append(Excluded(generation))
                self._rejoin(now)
            self.members, self.phy_id = members, None
            return
        phy_id = ids.index(self.me.member_id)
        self.members, self.phy_id, self.self_ids = members, phy_id, {}
        self._coordinator = ids[0]
        self._silence_since = self._reset_time = now
        self._last_heartbeat = -math.inf
        was_coordinator = self.role is Role.coordinator
        self.role = Role.coordinator if phy_id == 0 else Role.member
        if self.role is Role.coordinator:
            boss = self._boss
            if not was_coordinator:
                boss.joins.clear()
                boss.leaves.clear()
            # A reset renews no lease: a silent member (an idle host) never sends its
            # self-ID, and if every repeated self-ID phase renewed its lease it would
            # never run out, and nobody on the bus would ever be ready.
            heard = boss.last_heard if was_coordinator else {}
            boss.last_heard = {m.member_id: heard.get(m.member_id, now) for m in members}
            boss.reset_due, boss.initiator = None, 0
            boss.last_beacon = -math.inf
        raw = self_id_bytes(
            phy_id,
            len(members),
            contender=self.me.contender,
            initiated_reset=initiator == self.me.member_id,
        )
        self.self_ids[phy_id] = raw
        self._send(FrameKind.phy_packet, EVERY_MEMBER, raw)
        self._changes.append(BusReset(generation, phy_id, members, initiator))

    def _on_join(self, join: tuple[MemberInfo, int], now: float) -> None:
        info, target = join
        if self.role is not Role.coordinator or target not in (0, self.me.member_id):
            return
        listed = any(m.member_id == info.member_id for m in self.members)
        if listed and now - self._reset_time < self.timing.lease / 2:
            # Sent before our reset reached it: that reset is on its way. A joiner
            # whose reset really got lost asks again after this grace time.
            return
        self._boss.joins[info.member_id] = info
        self._boss.leaves.discard(info.member_id)
        self._schedule_reset(now, info.member_id)

    def _on_leave(self, header: FrameHeader, now: float) -> None:
        gone = header.sender
        if self.role is Role.coordinator:
            if any(m.member_id == gone for m in self.members):
                self._boss.leaves.add(gone)
                self._schedule_reset(now, self.me.member_id)
            self._boss.joins.pop(gone, None)
        elif self.role is Role.member and gone == self._coordinator and self.phy_id == 1:
            # Only the next in the succession steps in; the others hear its reset.
            self._take_over(now, dead={gone})
        self._coordinators.pop(gone, None)

    # -- time -------------------------------------------------------------------------
    def tick(self, now: float) -> None:
        t = self.timing
        away, self._awake_at = now - self._awake_at, now
        if away > 2 * t.heartbeat and self.role is not Role.joining:
            self._back_from_pause(away)
        if self.role is Role.joining:
            if now - self._silence_since >= self._listen:
                self._found_bus(now)
            elif now - self._last_join >= t.join_retry:
                self._send_join(now)
            return
        if now - self._last_heartbeat >= t.heartbeat:
            self._last_heartbeat = now
            if self.role is Role.member:
                self._send(FrameKind.heartbeat, 0)
        if self.role is Role.member:
            assert self.phy_id is not None
            if now - self._silence_since > t.lease * self.phy_id:
                dead = {m.member_id for m in self.members[: self.phy_id]}
                self._take_over(now, dead)
            return
        self._coordinate(now)

    def _back_from_pause(self, away: float) -> None:
        """This process did not run for ``away`` seconds (stopped, or starved of CPU).

        Silence while we were not listening says nothing about the others: it must
        neither make us take over (the bus would get a second physical ID 0) nor
        end the leases of members we could not hear. What the bus said meanwhile
        is queued on our socket and comes next; if it dropped us, that includes
        the reset that left us out, and we join again then.
        """
        self._silence_since += away
        boss = self._boss
        boss.last_heard = {member: heard + away for member, heard in boss.last_heard.items()}

    def _coordinate(self, now: float) -> None:
        t, boss = self.timing, self._boss
        if now - boss.last_beacon >= t.heartbeat:
            boss.last_beacon = now
            self._send(FrameKind.beacon, EVERY_MEMBER, pack_table(self.members))
            for member in self.members[1:]:
                if now - boss.last_heard.get(member.member_id, now) > t.lease:
                    boss.leaves.add(member.member_id)
                    self._schedule_reset(now, self.me.member_id)
        if not self.ready and now - self._reset_time > t.self_id_timeout:
            self._schedule_reset(now, self.me.member_id)
        if boss.reset_due is not None and now >= boss.reset_due:
            self._reset(now)

    def mark_dead(self, member_id: int, now: float) -> None:
        """The station learnt that a member's process is gone (faster than its lease)."""
        if self.role is Role.coordinator and any(m.member_id == member_id for m in self.members):
            self._boss.leaves.add(member_id)
            self._schedule_reset(now, self.me.member_id)

    # -- coordinator actions ----------------------------------------------------------
    def _schedule_reset(self, now: float, initiator: int) -> None:
        boss = self._boss
        if boss.reset_due is None:
            boss.reset_due = now + self.timing.settle
            boss.initiator = initiator

    def _reset(self, now: float) -> None:
        boss = self._boss
        kept = [m for m in self.members if m.member_id not in boss.leaves]
        kept_ids = {m.member_id for m in kept}
        joiners = sorted(
            (m for m in boss.joins.values() if m.member_id not in kept_ids),
            key=lambda m: m.sort_key,
        )
        # Members already on the bus keep their places; joiners fill what is left.
        room = MAX_MEMBERS - len(kept)
        for refused in joiners[room:]:
            self._send(
                FrameKind.refused,
                EVERY_MEMBER,
                pack_refusal(
                    refused.member_id,
                    f"bus is full: {MAX_MEMBERS} nodes is the IEEE 1394 limit",
                ),
            )
        # A joiner that is already listed missed its reset: the new one includes it again.
        members = tuple(sorted(kept + joiners[:room], key=lambda m: m.sort_key))
        generation = max(self.generation, self._highest_generation) + 1
        initiator = boss.initiator
        boss.joins.clear()
        boss.leaves.clear()
        boss.reset_due = None
        self._send(FrameKind.bus_reset, EVERY_MEMBER, pack_table(members, initiator))
        self._enter(generation, members, initiator, now)

    def _found_bus(self, now: float) -> None:
        """No coordinator answered: start a bus of our own."""
        self.role = Role.coordinator
        self.members = ()
        self._boss = _CoordinatorState()
        self._boss.joins[self.me.member_id] = self.me
        self._boss.initiator = self.me.member_id
        self._boss.reset_due = now
        self._reset(now)

    def _take_over(self, now: float, dead: set[int]) -> None:
        """The coordinator (and everyone before us in the succession) went silent."""
        self.members = tuple(m for m in self.members if m.member_id not in dead)
        self.role = Role.coordinator
        self._boss = _CoordinatorState(last_heard={m.member_id: now for m in self.members})
        for member_id in dead:
            self._coordinators.pop(member_id, None)
        self._schedule_reset(now, self.me.member_id)
        self._boss.reset_due = now
        self._reset(now)

    # -- joining ----------------------------------------------------------------------
    def _rejoin(self, now: float) -> None:
        self.role = Role.joining
        self.phy_id = None
        self._silence_since = now
        self._listen = self.timing.lease
        self._send_join(now)

    def _send_join(self, now: float) -> None:
        self._last_join = now
        target = self._best_coordinator(now) or 0
        self._send(FrameKind.join, EVERY_MEMBER, pack_join(self.me, target))

    def _send(self, kind: FrameKind, destination: int, payload: bytes = b"") -> None:
        self._outgoing.append(Outgoing(kind, destination, payload))
