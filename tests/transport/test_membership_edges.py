"""Bus management at its edges: a coordinator that says goodbye, a member that leaves,
beacons from a second coordinator, who sends heartbeats (docs/virtual-bus.md: members
send heartbeats to the coordinator, the coordinator sends beacons)."""

from __future__ import annotations

from dataclasses import replace

from fake_bus import FAKE_TIMING, TAG, FakeBus, settled

from fw1394.transport.sansio.membership import Membership, Role
from fw1394.transport.sansio.wire import (
    EVERY_MEMBER,
    FrameHeader,
    FrameKind,
    MemberInfo,
    pack_table,
)


def test_the_next_member_steps_in_at_once_when_the_coordinator_leaves() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(3)]
    bus.run(1.5)
    nodes[0].leave()
    bus.deliver()
    bus.kill(nodes[0])
    # A fifth of a lease: silence alone would not have made anyone take over yet.
    bus.run(FAKE_TIMING.lease / 5)
    _, members = settled(bus)
    assert [m.rank for m in members] == [1, 2]
    assert nodes[1].role is Role.coordinator and nodes[2].role is Role.member


def test_a_member_leaving_is_one_reset_by_the_coordinator_and_no_take_over() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank, member_id=5000 + rank) for rank in range(3)]
    bus.run(1.5)
    before, _ = settled(bus)
    nodes[2].leave()
    bus.deliver()
    bus.kill(nodes[2])
    for _ in range(30):
        bus.run(0.01)
        assert nodes[0].role is Role.coordinator and nodes[1].role is Role.member
    after, members = settled(bus)
    assert [m.rank for m in members] == [0, 1] and after == before + 1


def beacon_from_stranger(
    sender: int, table: tuple[MemberInfo, ...], generation: int
) -> tuple[FrameHeader, bytes]:
    return FrameHeader(FrameKind.beacon, TAG, sender, generation, 0, EVERY_MEMBER), pack_table(
        table
    )


def test_a_member_yields_only_to_a_coordinator_with_a_lower_key() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in (3, 4)]
    bus.run(1.5)
    generation, _ = settled(bus)
    member = nodes[1]
    # A second coordinator with a higher key (rank 9): ignored.
    header, payload = beacon_from_stranger(9999, (MemberInfo(9999, 9),), generation)
    member.receive(header, payload, bus.now)
    assert member.role is Role.member and not member.outgoing()
    # One with a lower key (rank 0): the member leaves its bus to join that one.
    header, payload = beacon_from_stranger(7777, (MemberInfo(7777, 0),), generation)
    member.receive(header, payload, bus.now)
    assert member.phy_id is None
    assert [out.kind for out in member.outgoing()] == [FrameKind.join]


def test_a_beacon_whose_table_does_not_list_its_sender_is_ignored() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank, member_id=5000 + rank) for rank in (3, 4)]
    bus.run(1.5)
    generation, _ = settled(bus)
    # Sender 9999 lists only member 5 (rank 0, a lower key than the coordinator's).
    header, payload = beacon_from_stranger(9999, (MemberInfo(5, 0),), generation)
    nodes[1].receive(header, payload, bus.now)
    assert nodes[1].role is Role.member and not nodes[1].outgoing()


def test_only_members_send_heartbeats() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(2)]
    bus.run(1.5)
    settled(bus)
    sent: dict[int, list[int]] = {0: [], 1: []}
    # Less than a lease without frames delivered: nobody takes over meanwhile.
    for _ in range(30):
        bus.now += 0.01
        for index, node in enumerate(nodes):
            node.tick(bus.now)
            sent[index] += [out.kind for out in node.outgoing()]
    assert FrameKind.heartbeat not in sent[0] and FrameKind.beacon in sent[0]
    assert FrameKind.heartbeat in sent[1] and FrameKind.beacon not in sent[1]


def test_a_death_is_one_reset_a_settle_time_later_and_only_for_a_member() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank, member_id=5000 + rank) for rank in range(3)]
    bus.run(1.5)
    before, _ = settled(bus)
    coordinator = nodes[0]
    # A process the station saw die that is no member of this bus: nothing to do.
    coordinator.mark_dead(9999, bus.now)
    bus.run(FAKE_TIMING.settle * 3)
    assert settled(bus)[0] == before
    # A member's death: one reset, once the settle time has passed and not before.
    bus.kill(nodes[2])
    coordinator.mark_dead(5002, bus.now)
    fine = FAKE_TIMING.settle / 20
    bus.run(FAKE_TIMING.settle * 0.9, step=fine)
    assert coordinator.generation == before
    bus.run(FAKE_TIMING.settle * 0.2, step=fine)
    assert coordinator.generation == before + 1
    bus.run(0.2)  # the self-ID phase of the new generation
    after, members = settled(bus)
    assert after == before + 1 and [m.rank for m in members] == [0, 1]


def test_an_incomplete_self_id_phase_is_repeated_after_its_timeout_not_before() -> None:
    # A listed member that sends no self-ID (killed between two resets, its lease
    # far from over) leaves the coordinator not ready: it resets again once the
    # phase has lasted self_id_timeout, and not earlier.
    timing = replace(FAKE_TIMING, lease=30.0, self_id_timeout=0.3)
    bus = FakeBus(timing)
    boss = Membership(MemberInfo(1000, 0), bus.now, replace(timing, found_after=0.0))
    bus.members[1000] = boss
    quiet = bus.add(1)
    bus.run(0.5)
    settled(bus)
    bus.kill(quiet)
    boss.request_reset(bus.now)
    bus.run(0.05)
    phase = boss.generation
    assert not boss.ready
    bus.run(0.2)  # 0.25 s into the phase
    assert boss.generation == phase
    bus.run(0.1)  # 0.35 s
    assert boss.generation == phase + 1 and not boss.ready
