"""QLA boards as processes of the virtual 1394 bus, reached by the host over Eth1394.

``fw1394 bus up --board qla1 --nodes N --eth1394``: in bridge mode (firmware
8) the rank-0 node is the hub and forwards the host's requests over the
virtual bus by FireWire node ID; in Ethernet-only mode (firmware 9, only in
a network namespace this test creates) every board has its own address and
the hub collects the broadcast query's blocks over the bus.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator

import pytest
from bus_support import bus_name

PORT = 30_000 + (os.getpid() + 7) % 20_000


def fw1394(*args: str, namespace: str | None = None) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "fw1394.cli.main", *args]
    if namespace is not None:
        command = ["ip", "netns", "exec", namespace, *command]
    return subprocess.run(command, capture_output=True, text=True, timeout=60)


def check_loop(endpoint: str, boards: int, namespace: str | None = None) -> str:
    """Both loops run every cycle complete; the mode the scan they began with found.

    Each ``jhu rt`` scans first, as the host library does; its JSON reports that
    scan as ``jhu scan --json`` prints it."""
    modes = set()
    for protocol in ("sequential", "broadcast-read-write"):
        run = fw1394(
            "jhu", "rt", "-p", f"udp:{endpoint}", "--cycles", "100", "--protocol", protocol,
            "--receive-timeout", "0.2",
            "--json", namespace=namespace,
        )  # fmt: skip
        assert run.returncode == 0, run.stderr + run.stdout
        report = json.loads(run.stdout)
        assert report["complete"] == 100
        assert [b["board_id"] for b in report["scan"]["boards"]] == list(range(boards))
        modes.add(report["scan"]["mode"])
    (mode,) = modes
    return str(mode)


@pytest.mark.process
@pytest.mark.slow
def test_bridge_hub_on_the_virtual_bus() -> None:
    name = bus_name("jhu")
    # A lease well above a loaded machine's scheduling delays: a member dropped
    # for a late heartbeat resets the bus, and the cycle it cuts fails the loop.
    fast = ("--heartbeat", "0.05", "--lease", "2")
    up = fw1394("bus", "up", "--name", name, "--board", "qla1", "--nodes", "3",
                "--eth1394", f"127.0.0.1:{PORT}", *fast)  # fmt: skip
    try:
        assert up.returncode == 0, up.stderr
        assert check_loop(f"127.0.0.1:{PORT}", 3) == "bridge"
    finally:
        fw1394("bus", "down", "--name", name)


@pytest.mark.process
def test_eth1394_needs_a_qla1_board() -> None:
    done = fw1394("bus", "up", "--name", bus_name("jhu"), "--nodes", "1", "--eth1394")
    assert done.returncode != 0 and "qla1" in done.stderr


@pytest.fixture
def namespace() -> Iterator[str]:
    if os.geteuid() != 0 or shutil.which("ip") is None:
        pytest.skip("needs root and iproute2 (ip) to create a network namespace")
    name = f"fwjhub{os.getpid() % 100000}"
    subprocess.run(["ip", "netns", "add", name], check=True, capture_output=True, timeout=10)
    try:
        for args in (("link", "set", "lo", "up"), ("route", "add", "224.0.0.0/4", "dev", "lo")):
            subprocess.run(["ip", "-n", name, *args], check=True, capture_output=True, timeout=10)
        yield name
    finally:
        subprocess.run(["ip", "netns", "del", name], capture_output=True, timeout=10)


@pytest.mark.process
@pytest.mark.netns
@pytest.mark.slow
def test_ethernet_only_boards_on_the_virtual_bus(namespace: str) -> None:
    name = bus_name("jhu9")
    up = fw1394("bus", "up", "--name", name, "--board", "qla1", "--nodes", "2",
                "--firmware", "9", "--eth1394", namespace=namespace)  # fmt: skip
    try:
        assert up.returncode == 0, up.stderr
        mode = check_loop("127.0.0.1", 2, namespace)
        assert mode == "ethernet-only"
    finally:
        fw1394("bus", "down", "--name", name, namespace=namespace)
