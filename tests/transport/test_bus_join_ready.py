"""A host that is ready can address every node at once, as after a 1394 self-ID phase.

Real node processes on loopback. A node re-attaches its kernel filter (its
link's address recognition) when a reset gives it a new physical ID; on a busy
machine the scheduler can run other processes between that node's self-ID and
its new filter, and a request that arrives in between is dropped by the kernel
for good. The "slow link" nodes here stretch that gap to LINK_DELAY so that the
order of the two steps, not the scheduler, decides whether a request is lost.
"""

from __future__ import annotations

import subprocess
import sys
import threading
import time

import pytest
from bus_support import bus_name, node_command, stop, wait_until_gone
from fake_bus import FakeBus, settled

from fw1394.engine import ReadCompleted, TransactionEvent, TransactionFailed
from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing

# self_id_timeout (1 s) below the lease, as on every bus the tests and benches run:
# a reset must not renew the lease of a member that stays silent through it.
TIMING = Timing(heartbeat=0.1, lease=1.5)
ARGS = ("--heartbeat", "0.1", "--lease", "1.5")
# Longer than a host takes from its last self-ID to its first request, even stalled.
LINK_DELAY = 0.4
# Generous: a lost request, not a slow machine, is what these tests catch.
ACK_TIMEOUT = 1.0

_SLOW_LINK = f"""
import sys, time
from fw1394.cli.bus import standalone
from fw1394.transport.media.udp import Medium

attach = Medium.filter_as_member

def slowly(self, member_id, phy_id, drop_acks):
    if phy_id is not None:
        time.sleep({LINK_DELAY})  # the scheduler ran something else first
    attach(self, member_id, phy_id, drop_acks)

Medium.filter_as_member = slowly
sys.exit(standalone(sys.argv[1:]))
"""


def start_slow_node(name: str, rank: int) -> subprocess.Popen[bytes]:
    arguments = node_command(name, rank, *ARGS)[3:]  # after "python -m fw1394.cli.bus"
    return subprocess.Popen(
        [sys.executable, "-c", _SLOW_LINK, *arguments], stdin=subprocess.DEVNULL
    )


def start_node(name: str, rank: int) -> subprocess.Popen[bytes]:
    return subprocess.Popen(node_command(name, rank, *ARGS), stdin=subprocess.DEVNULL)


def port_on(name: str) -> BusPort:
    return BusPort(
        BusConfig(name), timing=TIMING, ack_timeout=ACK_TIMEOUT, split_timeout=ACK_TIMEOUT
    )


def outcome(event: TransactionEvent) -> str:
    if isinstance(event, TransactionFailed):
        return str(event.reason)
    assert isinstance(event, ReadCompleted)
    return "ok"


def read_every_node_at_once(port: BusPort, count: int) -> dict[int, str]:
    """Wait until ``count`` nodes are on the bus, then read each of them at once."""
    limit = time.monotonic() + 30
    while len(nodes := port.nodes()) < count:
        assert time.monotonic() < limit, f"only {len(nodes)} of {count} nodes joined"
        port.poll(0.002)
    tids = {phy: port.start_read_quadlet(phy, 0) for phy, member in nodes if not member.host}
    return {phy: outcome(port.wait(tid)) for phy, tid in tids.items()}


@pytest.mark.process
def test_nodes_answer_the_host_the_moment_it_is_ready(
    node_processes: list[subprocess.Popen[bytes]],
) -> None:
    name = bus_name("ready")
    with port_on(name) as port:
        # The host is first: each node joins its bus and takes a new physical ID in
        # the reset after which the host reads it (rank 0 moves rank 1 up as well).
        node_processes.append(start_slow_node(name, 1))
        assert read_every_node_at_once(port, 1) == {0: "ok"}
        node_processes.append(start_slow_node(name, 0))
        assert read_every_node_at_once(port, 2) == {0: "ok", 1: "ok"}
        assert [m.board_id for _, m in port.nodes()] == [0, 1]
    for process in node_processes:
        stop(process)
    assert wait_until_gone(name) == []


@pytest.mark.process
def test_a_host_joins_beside_an_active_host_and_reads_at_once(
    node_processes: list[subprocess.Popen[bytes]],
) -> None:
    name = bus_name("beside")
    node_processes += [start_node(name, rank) for rank in range(2)]
    with port_on(name) as first:
        read_every_node_at_once(first, 2)
        done = threading.Event()
        outcomes: list[str] = []

        def keep_busy() -> None:
            # The other host stays on the bus (and takes part in the reset) meanwhile.
            while not done.is_set():
                outcomes.append(outcome(first.wait(first.start_read_quadlet(0, 0))))

        busy = threading.Thread(target=keep_busy)
        busy.start()
        try:
            with port_on(name) as second:
                assert read_every_node_at_once(second, 3) == {0: "ok", 1: "ok"}
        finally:
            done.set()
            busy.join(10)
        # Only the resets of the second host's coming and going may end its reads.
        assert set(outcomes) <= {"ok", "bus_reset"} and "ok" in outcomes, outcomes


@pytest.mark.process
def test_a_host_joins_beside_an_idle_host(
    node_processes: list[subprocess.Popen[bytes]],
) -> None:
    name = bus_name("idle")
    node_processes.append(start_node(name, 0))
    with port_on(name) as idle:
        assert read_every_node_at_once(idle, 1) == {0: "ok"}
        # ``idle`` runs no timers from now on: it sends neither heartbeats nor the
        # self-ID of the reset the second host causes, so its lease must run out.
        started = time.monotonic()
        with port_on(name) as second:
            second.join_timeout = 4 * TIMING.lease
            assert read_every_node_at_once(second, 1) == {0: "ok"}
            assert [m.host for m in second.members] == [False, True]
        assert time.monotonic() - started < 3 * TIMING.lease


@pytest.mark.process
def test_a_host_left_idle_reads_again_at_once(
    node_processes: list[subprocess.Popen[bytes]],
) -> None:
    """Idle for a while, within the lease, around its end, well past it: no failure.

    A host runs its timers only inside its calls; the first transaction after a
    pause must not meet a bus reset that the pause caused.
    """
    name = bus_name("pause")
    node_processes.append(start_node(name, 0))
    with port_on(name) as port:
        assert read_every_node_at_once(port, 1) == {0: "ok"}
        pauses = (3 * TIMING.heartbeat, TIMING.lease - TIMING.heartbeat / 2, TIMING.lease + 0.5)
        for pause in pauses:
            time.sleep(pause)
            assert outcome(port.wait(port.start_read_quadlet(0, 0))) == "ok", pause
            assert [m.host for _, m in port.nodes()] == [False]


def test_a_reset_does_not_renew_the_lease_of_a_silent_member() -> None:
    timing = Timing(heartbeat=0.1, lease=1.5, join_retry=0.05, settle=0.002)
    bus = FakeBus(timing)
    nodes = [bus.add(rank) for rank in range(3)]
    bus.run(3.0)
    settled(bus)
    bus.kill(nodes[2])  # silent from now on, as an idle host is
    bus.add(3)  # and a join resets the bus at once: a self-ID phase it never finishes
    bus.run(2 * timing.lease)
    _, members = settled(bus)
    assert [m.rank for m in members] == [0, 1, 3]
