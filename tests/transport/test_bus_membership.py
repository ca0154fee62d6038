"""Bus management without sockets: membership state machines joined by a fake medium."""

from __future__ import annotations

import pytest
from fake_bus import FAKE_TIMING, FakeBus, settled

from fw1394.packets import PortStatus, SelfIdPacket, decode
from fw1394.transport.sansio.membership import BusReset, Membership, Refused, Role, Timing
from fw1394.transport.sansio.wire import MAX_MEMBERS, MemberInfo


def test_ids_follow_rank_and_the_host_is_root() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in (2, 0, 1)]
    bus.run(1.5)
    host = bus.add(10**18, contender=True)
    bus.run(0.5)
    generation, members = settled(bus)
    assert [m.rank for m in members] == [0, 1, 2, 10**18]
    assert host.phy_id == 3
    assert [n.phy_id for n in nodes] == [2, 0, 1]
    assert sum(m.role is Role.coordinator for m in bus.live()) == 1
    assert members[0].rank == 0 and nodes[1].role is Role.coordinator
    assert generation >= 2


def test_self_ids_describe_a_chain_with_the_root_at_the_end() -> None:
    bus = FakeBus()
    for rank in range(4):
        bus.add(rank)
    bus.run(2.0)
    settled(bus)
    packets = {phy: decode(raw) for phy, raw in bus.live()[0].self_ids.items()}
    assert sorted(packets) == [0, 1, 2, 3]
    for phy, packet in packets.items():
        assert isinstance(packet, SelfIdPacket)
        assert packet.phy_id == phy and packet.link_active
        assert packet.gap_count == 0x3F
        expected_parent = PortStatus.not_connected if phy == 3 else PortStatus.parent
        assert packet.port0 == expected_parent
        assert packet.port1 == (PortStatus.child if phy else PortStatus.not_connected)


def test_a_silent_member_is_dropped_and_the_generation_moves_on() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(3)]
    bus.run(1.5)
    before, _ = settled(bus)
    bus.kill(nodes[1])
    bus.run(1.0)
    after, members = settled(bus)
    assert after > before
    assert [m.rank for m in members] == [0, 2]
    assert nodes[2].phy_id == 1


def test_the_next_member_takes_over_when_the_coordinator_dies() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(3)]
    bus.run(1.5)
    bus.kill(nodes[0])
    bus.run(1.5)
    _, members = settled(bus)
    assert [m.rank for m in members] == [1, 2]
    assert nodes[1].role is Role.coordinator


def test_a_returning_member_with_the_lowest_rank_becomes_coordinator_again() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(3)]
    bus.run(1.5)
    bus.kill(nodes[0])
    bus.run(1.5)
    back = bus.add(0, member_id=5000)
    bus.run(1.0)
    _, members = settled(bus)
    assert [m.rank for m in members] == [0, 1, 2]
    assert back.role is Role.coordinator and back.phy_id == 0


def test_a_reset_request_bumps_the_generation_only() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(2)]
    bus.run(1.5)
    before, members = settled(bus)
    nodes[1].request_reset(bus.now)
    bus.run(0.3)
    after, again = settled(bus)
    assert after == before + 1 and again == members
    changes = [c for c in nodes[1].changes() if isinstance(c, BusReset)]
    assert changes[-1].initiator == nodes[1].me.member_id


def test_the_sixty_fourth_member_is_refused() -> None:
    bus = FakeBus()
    everyone = [bus.add(rank) for rank in range(MAX_MEMBERS)]
    bus.run(2.0)
    _, members = settled(bus)
    assert len(members) == MAX_MEMBERS
    extra = bus.add(1000)
    bus.run(0.3)
    refusals = [c for c in extra.changes() if isinstance(c, Refused)]
    assert refusals and "63" in refusals[0].reason
    assert all(m.phy_id is not None for m in everyone)


@pytest.mark.parametrize("ranks", [(5, 3), (3, 5)])
def test_two_lone_coordinators_merge(ranks: tuple[int, int]) -> None:
    bus = FakeBus()
    first = bus.add(ranks[0])
    bus.run(1.0)
    # A second bus founded while the first one's beacons did not reach it.
    second = Membership(MemberInfo(77, ranks[1]), bus.now, FAKE_TIMING)
    second.tick(bus.now + FAKE_TIMING.lease)
    second.outgoing()
    bus.members[77] = second
    bus.run(1.5)
    _, members = settled(bus)
    assert sorted(m.rank for m in members) == sorted(ranks)
    assert first.generation == second.generation


@pytest.mark.parametrize(("wait", "resets"), [(0.1, 2), (0.5, 1)])
def test_a_rejoin_after_half_a_lease_is_one_reset(wait: float, resets: int) -> None:
    # A join from a listed member within half a lease of a reset was sent before
    # that reset reached it and is ignored (the leave makes one reset, the repeated
    # join a second); later, leave and join share one reset. A lease of 0.8 s puts
    # half a lease (0.4 s) apart from a lease squared (0.64 s).
    timing = Timing(heartbeat=0.1, lease=0.8, join_retry=0.05, settle=0.002, self_id_timeout=0.5)
    bus = FakeBus(timing)
    coordinator, member = bus.add(0), bus.add(1)
    bus.run(2.0)
    settled(bus)
    coordinator.request_reset(bus.now)
    bus.run(0.02)
    before, _ = settled(bus)
    bus.run(wait)
    member.rejoin(bus.now)
    bus.run(1.0)
    after, members = settled(bus)
    assert [m.rank for m in members] == [0, 1]
    assert after - before == resets


def test_a_joiner_sleeps_until_its_next_join_retry_or_the_end_of_its_lease() -> None:
    # A joiner asks every join_retry and founds its own bus after a lease of silence;
    # its station sleeps until whichever comes first.
    # (Binary fractions: the sums are exact.)
    timing = Timing(heartbeat=0.125, lease=0.5, join_retry=0.375, settle=0.002, self_id_timeout=0.5)
    joiner = Membership(MemberInfo(1000, 0), 0.25, timing)
    joiner.tick(0.25)  # the first join
    assert joiner.role is Role.joining
    assert joiner.next_deadline() == 0.625  # the next join
    joiner.tick(0.625)
    assert joiner.next_deadline() == 0.75  # the lease's end
    joiner.tick(0.75)
    assert joiner.role.name == "coordinator"  # by name: mypy would keep the narrowing above
