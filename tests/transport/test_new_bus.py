"""A new bus's first node starts it at once; every other member listens a lease first.

A joining member founds a bus of its own only after a lease without a
coordinator's beacon, so that a coordinator stopped for less than that is not
replaced. ``bus up`` knows when nobody can be on the bus (it stays on this host
and none of its members runs here): its first node is told so and starts the
bus without that wait; a node that rejoins, or is started again, never skips it.
"""

from __future__ import annotations

import os
import signal
import time
from dataclasses import replace
from pathlib import Path

import pytest
from bus_support import bus_name, start_node, stop, wait_until_gone
from fake_bus import FAKE_TIMING, TAG, FakeBus, settled

from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Membership, Role
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, MemberInfo
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.observe import watch
from fw1394.transport.supervision.runtime import bus_dir, read_members

NEW = replace(FAKE_TIMING, found_after=0.0)
ARGS = ("--heartbeat", "0.1", "--lease", "2.0")


def test_the_first_node_of_a_new_bus_founds_it_at_its_first_tick() -> None:
    first = Membership(MemberInfo(1, 0), 0.0, NEW)
    first.tick(0.0)
    assert first.role is Role.coordinator and first.generation == 1
    # It never asked to join: there was nobody to ask.
    assert [out.kind for out in first.outgoing()] == [FrameKind.bus_reset, FrameKind.phy_packet]


def test_others_join_the_new_bus_well_within_a_lease() -> None:
    bus = FakeBus()
    founder = Membership(MemberInfo(1, 0), bus.now, NEW)
    bus.members[1] = founder
    others = [bus.add(rank) for rank in (1, 2)]
    bus.run(FAKE_TIMING.lease / 5)
    _, members = settled(bus)
    assert [m.rank for m in members] == [0, 1, 2]
    assert founder.role is Role.coordinator and [o.phy_id for o in others] == [1, 2]


def test_without_the_promise_a_joiner_listens_a_whole_lease() -> None:
    bus = FakeBus()
    joiner = bus.add(0)
    bus.run(FAKE_TIMING.lease * 0.9)
    assert joiner.role is Role.joining
    bus.run(FAKE_TIMING.lease * 0.2)
    assert joiner.role.name == "coordinator"  # by name: mypy keeps the narrowing above


@pytest.mark.parametrize("ranks", [(5, 3), (3, 5)])
def test_a_wrong_promise_ends_in_one_bus(ranks: tuple[int, int]) -> None:
    """Told the bus is new while one is there: the two coordinators settle it, and the
    one that yields joins the other instead of founding again."""
    bus = FakeBus()
    there = bus.add(ranks[0])
    bus.run(1.0)
    late = Membership(MemberInfo(77, ranks[1]), bus.now, NEW)
    bus.members[77] = late
    bus.run(1.5)
    _, members = settled(bus)
    assert sorted(m.rank for m in members) == sorted(ranks)
    assert there.generation == late.generation
    assert sum(m.role is Role.coordinator for m in bus.live()) == 1


def test_a_member_that_heard_a_beacon_joins_instead_of_founding() -> None:
    coordinator = Membership(MemberInfo(1000, 0), 0.0, FAKE_TIMING)
    coordinator.tick(FAKE_TIMING.lease)  # alone: founds its bus
    coordinator.outgoing()
    coordinator.tick(FAKE_TIMING.lease + FAKE_TIMING.heartbeat)
    beacons = [out for out in coordinator.outgoing() if out.kind is FrameKind.beacon]
    assert beacons
    # The newcomer hears the bus before its first tick (its socket was open first).
    now = FAKE_TIMING.lease + FAKE_TIMING.heartbeat
    newcomer = Membership(MemberInfo(77, 9), now, NEW)
    header = FrameHeader(
        FrameKind.beacon, TAG, 1000, coordinator.generation, 0, beacons[0].destination
    )
    newcomer.receive(header, beacons[0].payload, now)
    newcomer.tick(now)
    assert newcomer.role is Role.joining
    assert [out.kind for out in newcomer.outgoing()] == [FrameKind.join]


def _cmdline(pid: int) -> list[str]:
    return Path(f"/proc/{pid}/cmdline").read_bytes().decode().split("\0")


@pytest.mark.process
def test_bus_up_tells_only_the_first_node_and_never_a_restarted_one(tmp_path: Path) -> None:
    config = BusConfig(bus_name("newbus"))
    with LaunchedBus(config, 2, root=tmp_path, node_arguments=ARGS, restart=True) as bus:
        assert "--new-bus" in bus.command()
        bus.wait_members()
        first, second = (record.pid for record in bus.records())
        assert "--new-bus" in _cmdline(first) and "--new-bus" not in _cmdline(second)
        os.kill(first, signal.SIGKILL)
        limit = time.monotonic() + 20
        while bus.records()[0].pid == first and time.monotonic() < limit:
            time.sleep(0.05)
        again = bus.records()[0].pid
        assert again != first and "--new-bus" not in _cmdline(again)
        # It joined the bus that was there (kept by the second node), as rank 0.
        view = watch(
            config, 20, lambda v: [m.pid for m in v.members if not m.host] == [again, second]
        )
        assert view is not None
    assert wait_until_gone(config.name) == []


@pytest.mark.process
def test_a_bus_with_a_member_running_here_or_beyond_this_host_is_not_new() -> None:
    name = bus_name("notnew")
    assert "--new-bus" not in LaunchedBus(BusConfig(name, ttl=1), 1).command()
    by_hand = start_node(name, 5, *ARGS)
    try:
        limit = time.monotonic() + 20
        while not read_members(bus_dir(name)) and time.monotonic() < limit:
            time.sleep(0.05)
        assert read_members(bus_dir(name))
        assert "--new-bus" not in LaunchedBus(BusConfig(name), 1).command()
    finally:
        stop(by_hand)
    assert wait_until_gone(name) == []
    assert "--new-bus" in LaunchedBus(BusConfig(name), 1).command()
