"""``python -m fw1394.node``: the node program a bus starts, as a real process on loopback."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bus_support import bus_name, stop, wait_until_gone

from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.launch import LaunchedBus

TIMING = Timing(heartbeat=0.1, lease=2.0)
ARGS = ("--heartbeat", "0.1", "--lease", "2.0")


def node(*options: str) -> list[str]:
    return [sys.executable, "-m", "fw1394.node", *options]


@pytest.mark.parametrize(
    ("options", "message"),
    [
        (("--board", "no-such-board"), "unknown board kind 'no-such-board'"),
        (("--eth1394",), "--eth1394 needs --board qla1, not memory"),
        (("--board", "qla1", "--eth1394", "192.0.2.1"), "not a loopback address"),
        (("--heartbeat", "3", "--lease", "1"), "must be positive and below --lease"),
        (("--defect", "no-such-defect"), "unknown defect 'no-such-defect'"),
        (("--board-id", "300"), "outside 0..254"),
        (("--name", "bad name!"), "bus name"),
    ],
)
@pytest.mark.process
def test_a_node_description_no_node_could_start_with_is_one_line(
    options: tuple[str, ...], message: str
) -> None:
    done = subprocess.run(node(*options), capture_output=True, text=True, timeout=30)
    assert done.returncode == 2
    assert "Traceback" not in done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("fw1394 node: error: ")
    assert message in lines[0]


@pytest.mark.process
def test_help_teaches_the_description() -> None:
    done = subprocess.run(node("--help"), capture_output=True, text=True, timeout=30)
    assert done.returncode == 0
    for option in ("--board", "--board-id", "--rank", "--policy", "--defect", "--eth1394"):
        assert option in done.stdout
    assert "snake2010" in done.stdout  # the kinds come from the board registry


@pytest.mark.process
def test_a_node_serves_a_host_and_leaves_on_sigterm() -> None:
    name = bus_name("nodemain")
    process = subprocess.Popen(
        node("--name", name, "--board-id", "7", "--rank", "0", "--quiet", *ARGS),
        stdin=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    try:
        with BusPort(BusConfig(name), timing=TIMING, ack_timeout=1.0, split_timeout=1.0) as port:
            limit = time.monotonic() + 30
            while not (nodes := port.nodes()):  # the process is still starting
                assert time.monotonic() < limit, "the node never joined"
                port.poll(0.01)
            ((phy, member),) = nodes
            assert (member.board_id, member.pid) == (7, process.pid)
            port.write_quadlet(phy, 0x30, 0x5EED1394)
            assert port.read_quadlet(phy, 0x30) == 0x5EED1394
        process.send_signal(signal.SIGTERM)
        assert process.wait(10) == 0
        assert process.stderr is not None and process.stderr.read() == b""
    finally:
        stop(process)


@pytest.mark.process
def test_a_bus_starts_its_nodes_through_the_node_program(tmp_path: Path) -> None:
    config = BusConfig(bus_name("nodeprog"))
    with LaunchedBus(
        config, 2, board="memory,snake2010", root=tmp_path, node_arguments=ARGS
    ) as bus:
        bus.wait_members()
        for record in bus.records():
            argv = Path(f"/proc/{record.pid}/cmdline").read_bytes().split(b"\0")
            assert argv[1:3] == [b"-m", b"fw1394.node"]
            assert argv[argv.index(b"--board") + 1] == record.board.encode()
            assert argv[argv.index(b"--parent-pid") + 1] != str(os.getpid()).encode()
    assert wait_until_gone(config.name) == []
