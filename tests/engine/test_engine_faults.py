"""The loopback injects the bus members' fault model, with the same meaning.

A delayed packet arrives ``delay_seconds`` late (as a bus member's delayed
frame leaves that late), a duplicate arrives right behind its packet, a lost
one never arrives; and the class a bus member is configured with is this one.
"""

from __future__ import annotations

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Requester, Responder
from fw1394.engine.faults import FaultConfig, FaultInjector
from fw1394.engine.loopback import Exchange, Link
from fw1394.engine.policy import POLICIES
from fw1394.transport import station


def _requests(faults: FaultConfig) -> list[Exchange]:
    requester = Requester(0xFFC1, ack_timeout=0.05, split_timeout=0.05, max_busy_retries=0)
    link = Link(requester, [Responder(0xFFC0, MemorySpace(64), POLICIES["thesis"])], faults=faults)
    requester.write_quadlet(0xFFC0, 4, 7, link.now)
    link.run(until=0.01)
    return [e for e in link.trace if e.kind == "request"]


def test_a_delayed_packet_arrives_delay_seconds_late() -> None:
    (request,) = _requests(FaultConfig(delay=1.0, delay_seconds=0.004))
    assert request.time == 0.004
    assert request.faults == ("delayed",)


def test_a_duplicate_arrives_right_behind_its_packet() -> None:
    first, copy = _requests(FaultConfig(duplicate=1.0))
    assert first.time == copy.time == 0.0
    assert (first.faults, copy.faults) == ((), ("duplicate",))
    assert first.packet == copy.packet


def test_a_lost_packet_never_arrives() -> None:
    (request,) = _requests(FaultConfig(loss=1.0))
    assert request.faults == ("dropped",)


def test_the_bus_and_the_loopback_share_one_model() -> None:
    # The bus member injects through the engine's model, not a copy of it.
    assert vars(station)["FaultInjector"] is FaultInjector
    # The bus member's view of the same settings: leaves 4 ms late, twice.
    both = FaultInjector(FaultConfig(delay=1.0, duplicate=1.0, delay_seconds=0.004))
    assert both.send_times(1.0) == [1.004, 1.004]
    assert not FaultConfig(corrupt=1.0, reorder=1.0, lose_ack=1.0).active  # loopback only
