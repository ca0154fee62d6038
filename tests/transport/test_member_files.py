"""``members/`` lists live processes only: the files of members that died go.

A member killed with SIGKILL cannot remove its own file; whoever reads the
directory next (``bus status``, ``bus down``, a member starting) does.
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.runtime import MEMBERS_DIR, read_members


def record(folder: Path, pid: int, member: int, suffix: str = ".json") -> Path:
    """A member file as the runtime docs describe it: members/<pid>-<member id hex>.json."""
    path = folder / f"{pid}-{member:08x}{suffix}"
    path.write_text(json.dumps({"pid": pid, "member_id": member, "host": False}))
    return path


def exited_pid() -> int:
    child = subprocess.Popen([sys.executable, "-c", "pass"])
    child.wait()
    return child.pid


@pytest.mark.process
def test_files_of_exited_processes_are_removed_when_read(tmp_path: Path) -> None:
    folder = tmp_path / MEMBERS_DIR
    folder.mkdir()
    mine = record(folder, os.getpid(), 0x11)
    dead = exited_pid()
    gone = record(folder, dead, 0x22)
    unfinished = record(folder, dead, 0x22, ".tmp")
    assert [r.pid for r in read_members(tmp_path)] == [os.getpid()]
    assert mine.exists()
    assert not gone.exists() and not unfinished.exists()


def member_pids(bus: AdapterBus) -> set[int]:
    folder = bus.directory / MEMBERS_DIR
    return {int(path.name.split("-")[0]) for path in folder.glob("*.json")}


@pytest.mark.process
def test_a_killed_node_leaves_no_file_behind() -> None:
    with adapter_bus("members", 2) as bus:
        nodes = [r.pid for r in bus.bus.records()]
        limit = time.monotonic() + 10
        while not set(nodes) <= member_pids(bus):
            assert time.monotonic() < limit, member_pids(bus)
            time.sleep(0.05)
        os.kill(nodes[1], signal.SIGKILL)
        limit = time.monotonic() + 10
        while os.path.exists(f"/proc/{nodes[1]}/cmdline") and time.monotonic() < limit:
            time.sleep(0.05)  # reaped by its supervisor
        assert nodes[1] in member_pids(bus)  # nobody has looked yet
        # A member starting looks: a host joining the bus.
        with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as port:
            port.wait_ready()
            assert nodes[1] not in member_pids(bus)
            assert {nodes[0], os.getpid()} <= member_pids(bus)
        assert os.getpid() not in member_pids(bus)  # a host leaving takes its own
