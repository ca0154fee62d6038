"""Supervision: a dead node comes back; ``bus down`` stops nodes joined by hand too."""

from __future__ import annotations

import os
import signal
import time
from pathlib import Path

import pytest
from bus_support import bus_name, start_node, stop, wait_until_gone

from fw1394.cli.main import main
from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.bus_key import new_key
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.procs import process_alive

ARGS = ("--heartbeat", "0.1", "--lease", "2.0")
TIMING = Timing(heartbeat=0.1, lease=2.0)


@pytest.mark.process
def test_a_killed_node_is_restarted_and_answers(tmp_path: Path) -> None:
    config = BusConfig(bus_name("restart"))
    with LaunchedBus(
        config, 2, root=tmp_path, node_arguments=ARGS, key=new_key(), restart=True
    ) as bus:
        bus.wait_members()
        victim = bus.records()[1].pid
        with BusPort(bus.member_config, timing=TIMING) as port:
            port.write_quadlet(1, 0x40, 0x1234)
            before = port.generation
            os.kill(victim, signal.SIGKILL)
            limit = time.monotonic() + 20
            while time.monotonic() < limit:
                port.poll(0.05)
                pid = bus.records()[1].pid
                if pid != victim and len(port.nodes()) == 2:
                    break
            assert bus.records()[1].pid != victim and process_alive(bus.records()[1].pid)
            # Same rank, so the same physical ID and board ID; a fresh memory, as a
            # power-cycled board's.
            assert [m.board_id for _, m in port.nodes()] == [0, 1]
            assert port.generation > before
            assert port.read_quadlet(1, 0x40) == 0
            port.write_quadlet(1, 0x40, 7)
            assert port.read_quadlet(1, 0x40) == 7
    assert wait_until_gone(config.name) == []


@pytest.mark.process
def test_bus_down_stops_a_node_joined_by_hand(capsys: pytest.CaptureFixture[str]) -> None:
    name = bus_name("byhand")
    assert main(["bus", "up", "--name", name, "--nodes", "1", *ARGS]) == 0
    by_hand = start_node(name, 5, *ARGS)
    try:
        config = BusConfig(name)
        with BusPort(config, timing=TIMING) as port:

            def boards() -> int:  # nodes, not the bus's host adapter
                return sum(not member.host for _, member in port.nodes())

            limit = time.monotonic() + 20
            while boards() < 2 and time.monotonic() < limit:
                port.poll(0.05)
            assert boards() == 2
        capsys.readouterr()
        assert main(["bus", "down", "--name", name]) == 0
        assert "1 nodes joined by hand stopped" in capsys.readouterr().out
        by_hand.wait(5)  # it is gone: not left running behind a bus that says it is down
    finally:
        stop(by_hand)
    assert wait_until_gone(name) == []
    assert main(["bus", "down", "--name", name]) == 2
