"""Bus management without sockets: a member that did not run, and stale requests."""

from __future__ import annotations

from fake_bus import TAG, FakeBus, settled

from fw1394.transport.sansio.membership import BusReset, Role
from fw1394.transport.sansio.wire import EVERY_MEMBER, FrameHeader, FrameKind


def test_a_member_that_did_not_run_never_takes_over() -> None:
    bus = FakeBus()
    nodes = [bus.add(rank) for rank in range(2)]
    host = bus.add(0, contender=True)
    bus.run(2.0)
    generation, members = settled(bus)
    assert host.phy_id == 2
    host.changes()  # those of getting on the bus
    bus.kill(host)  # stopped: it neither runs nor hears anything (its socket queue lost)
    bus.run(2.0)
    assert [m.member_id for m in nodes[0].members] == [n.me.member_id for n in nodes]
    bus.dead.discard(host.me.member_id)
    phys_seen = set()
    for _ in range(200):
        bus.run(0.01)
        phys_seen.add(host.phy_id)
        for change in host.changes():
            assert not isinstance(change, BusReset) or change.phy_id == 2
    # Before: four leases of silence made it take over as physical ID 0 at once.
    assert 0 not in phys_seen and host.role is not Role.coordinator
    generation_after, members_after = settled(bus)
    assert generation_after > generation and host.phy_id == 2
    assert [m.member_id for m in members_after] == [m.member_id for m in members]


def test_a_short_stall_of_the_coordinator_drops_nobody() -> None:
    bus = FakeBus()
    coordinator, *_ = [bus.add(rank) for rank in range(3)]
    bus.run(1.0)
    generation, _ = settled(bus)
    # Not run for 0.4 s (the lease is 0.5 s): the others' heartbeats queued meanwhile.
    bus.now += 0.4
    bus.run(1.0)
    assert settled(bus)[0] == generation
    assert coordinator.role is Role.coordinator


def test_a_reset_request_of_an_earlier_generation_is_ignored() -> None:
    bus = FakeBus()
    coordinator = bus.add(0)
    bus.add(1)
    bus.run(1.0)
    generation, _ = settled(bus)
    stale = FrameHeader(FrameKind.reset_request, TAG, 99, generation - 1, 0xFF, EVERY_MEMBER)
    coordinator.receive(stale, b"", bus.now)
    bus.run(0.5)
    assert settled(bus)[0] == generation
    current = stale._replace(generation=generation)
    coordinator.receive(current, b"", bus.now)
    bus.run(0.5)
    assert settled(bus)[0] == generation + 1
