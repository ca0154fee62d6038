"""One bus across three "machines": network namespaces joined by veth pairs and a bridge.

Everything (namespaces, veths, the bridge, addresses) is created by this test
in namespaces of its own and removed in ``finally``; nothing touches the
host's own interfaces or routes.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from collections.abc import Iterator

import pytest
from bus_support import bus_name, stop, wait_until_gone

pytestmark = [
    pytest.mark.skipif(
        os.geteuid() != 0 or shutil.which("ip") is None,
        reason="needs root and iproute2 (ip) to create network namespaces",
    ),
    pytest.mark.netns,
    pytest.mark.process,
    pytest.mark.slow,
]
SUBNET = "10.213.77"
FAST = ("--heartbeat", "0.05", "--lease", "0.5")


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=10)


@pytest.fixture
def lan() -> Iterator[dict[str, str]]:
    """Namespaces ``a``, ``b``, ``c`` on a bridge in namespace ``hub``: name -> address."""
    tag = f"fw{os.getpid() % 100000}"
    hub = f"{tag}hub"
    machines = {f"{tag}{letter}": f"{SUBNET}.{i + 1}" for i, letter in enumerate("abc")}
    created: list[str] = []
    try:
        for namespace in (hub, *machines):
            ip("netns", "add", namespace)
            created.append(namespace)
            ip("-n", namespace, "link", "set", "lo", "up")
        ip("-n", hub, "link", "add", "br0", "type", "bridge")
        ip("-n", hub, "link", "set", "br0", "up")
        for index, (namespace, address) in enumerate(machines.items()):
            inside, outside = f"{tag}i{index}", f"{tag}o{index}"
            ip(
                "link",
                "add",
                inside,
                "netns",
                namespace,
                "type",
                "veth",
                "peer",
                outside,
                "netns",
                hub,
            )
            ip("-n", hub, "link", "set", outside, "master", "br0", "up")
            ip("-n", namespace, "addr", "add", f"{address}/24", "dev", inside)
            ip("-n", namespace, "link", "set", inside, "up")
        yield machines
    finally:
        for namespace in created:
            subprocess.run(["ip", "netns", "del", namespace], capture_output=True, timeout=10)


def in_namespace(namespace: str, *command: str) -> list[str]:
    return ["ip", "netns", "exec", namespace, *command]


def fw1394(namespace: str, address: str, *args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "fw1394.cli.main", *args]
    command += ["--interface", address, "--ttl", "1"]
    if args[0] != "bus":
        command += FAST
    return subprocess.run(
        in_namespace(namespace, *command), capture_output=True, text=True, timeout=30
    )


def test_one_bus_spans_three_namespaces(lan: dict[str, str]) -> None:
    name = bus_name("lan")
    (ns_a, addr_a), (ns_b, addr_b), (ns_c, addr_c) = lan.items()
    nodes = []
    try:
        for rank, (namespace, address) in enumerate(((ns_a, addr_a), (ns_b, addr_b))):
            command = [sys.executable, "-m", "fw1394.cli.bus", "node", "run", "--name", name]
            command += ["--interface", address, "--ttl", "1", "--rank", str(rank), "--quiet"]
            command += ["--board-id", str(rank + 5), *FAST]
            nodes.append(subprocess.Popen(in_namespace(namespace, *command)))
        status = fw1394(ns_c, addr_c, "bus", "status", "--name", name, "--json", "--timeout", "5")
        # The first beacon may come before both nodes are in: look until they are.
        rows: list[dict[str, object]] = []
        for _ in range(10):
            rows = [json.loads(line) for line in status.stdout.splitlines()]
            if len(rows) == 2:
                break
            status = fw1394(ns_c, addr_c, "bus", "status", "--name", name, "--json")
        assert status.returncode == 0, status.stderr
        assert [(r["board_id"], r["address"]) for r in rows] == [(5, addr_a), (6, addr_b)]
        for phy in (0, 1):
            wrote = fw1394(ns_c, addr_c, "write", "--name", name, str(phy), "0x8", hex(0x50 + phy))
            assert wrote.returncode == 0, wrote.stderr
            read = fw1394(ns_c, addr_c, "read", "--name", name, str(phy), "0x8", "--json")
            assert read.returncode == 0, read.stderr
            assert json.loads(read.stdout)["data"] == f"{0x50 + phy:08x}"
    finally:
        for node in nodes:
            stop(node)
    assert wait_until_gone(name) == []
