"""Shared helpers of the bus tests: unique bus names, node processes, leftovers."""

from __future__ import annotations

import itertools
import os
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path

from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.observe import watch
from fw1394.transport.supervision.procs import process_alive
from fw1394.transport.supervision.stop import stop as stop

# The ``launch_bus`` fixture: ``launch_bus(nodes, tag=, board=, node_arguments=)``.
LaunchBus = Callable[..., LaunchedBus]

_counter = itertools.count()
PREFIX = f"fwtest{os.getpid()}"


def bus_name(tag: str) -> str:
    """A bus name no other test run on this machine uses."""
    return f"{PREFIX}-{tag}-{next(_counter)}"


def node_command(name: str, rank: int, *extra: str) -> list[str]:
    return [
        sys.executable,
        "-m",
        "fw1394.cli.bus",
        "node",
        "run",
        "--name",
        name,
        "--rank",
        str(rank),
        "--board-id",
        str(rank),
        "--parent-pid",
        str(os.getpid()),
        "--quiet",
        *extra,
    ]


def start_node(name: str, rank: int, *extra: str) -> subprocess.Popen[bytes]:
    return subprocess.Popen(node_command(name, rank, *extra), stdin=subprocess.DEVNULL)


def processes_mentioning(text: str) -> list[int]:
    """Live processes whose command line contains ``text``."""
    found = []
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            cmdline = (entry / "cmdline").read_bytes()
        except OSError:
            continue
        if text.encode() in cmdline and process_alive(int(entry.name)):
            found.append(int(entry.name))
    return found


def wait_until_gone(text: str, seconds: float = 5.0) -> list[int]:
    limit = time.monotonic() + seconds
    while (left := processes_mentioning(text)) and time.monotonic() < limit:
        time.sleep(0.05)
    return left


def wait_hosts_dropped(config: BusConfig, timeout: float = 30.0) -> None:
    """Return once the coordinator beacons a member table without hosts.

    A host that has not run (stopped, or blocked in the test) for a lease is
    dropped; this waits for exactly that instead of sleeping for a guess.
    """
    hostless = watch(config, timeout, lambda view: not any(m.host for m in view.members))
    assert hostless is not None, f"bus {config.name!r} still had a host after {timeout} s"
