"""A host process stopped (SIGSTOP) for seconds and continued: it goes on as documented.

docs/virtual-bus.md promises that a host back from a pause catches up before it
sends anything: a transaction after the pause does not fail, and the host never
takes over the bus (physical ID 0) because it heard nothing while it was stopped.
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
from bus_support import bus_name, wait_hosts_dropped, wait_until_gone
from polling import wait_until

from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

# A lease of 2 s: a loaded machine that stalls a node for a second resets no bus here.
ARGS = ("--heartbeat", "0.1", "--lease", "2.0")

# A host in its own process, keeping ``depth`` reads of known values outstanding
# until SIGUSR1 (or a minute) and printing every outcome and every bus reset it
# took part in as JSON lines.
HOST_PROGRAM = r"""
import json, signal, sys, time
from collections import deque
from fw1394.engine import ReadCompleted, TransactionFailed
from fw1394.transport.bus_host import BusHost
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing

name, depth = sys.argv[1], int(sys.argv[2])
told = []
signal.signal(signal.SIGUSR1, lambda *_: told.append(True))
host = BusHost(BusConfig(name), timing=Timing(heartbeat=0.1, lease=2.0),
               ack_timeout=0.3, split_timeout=0.3)
seen = 0
def report(**fields):
    print(json.dumps(fields), flush=True)
host.wait_ready()
nodes = [phy for phy, _ in host.nodes()]
report(kind="ready", phy=host.phy_id, nodes=nodes)
for node in nodes:  # quadlet q of node n holds n * 1000 + q
    for quadlet in range(64):
        host.wait(host.start_write_quadlet(node, 4 * quadlet, node * 1000 + quadlet))
limit, count, pending = time.monotonic() + 60, 0, deque()
def going():
    return not told and time.monotonic() < limit
while going() or pending:
    while len(pending) < depth and going():
        count += 1
        node, quadlet = nodes[count % len(nodes)], count % 64
        started = time.monotonic()
        tid = host.start_read_quadlet(node, 4 * quadlet)  # returns once the request is out
        pending.append((tid, node * 1000 + quadlet, started, time.monotonic()))
    tid, expected, started, sent = pending.popleft()
    event = host.wait(tid)
    for change in host.resets[seen:]:
        report(kind="reset", phy=change.phy_id, generation=change.generation)
    seen = len(host.resets)
    failed = [str(event.reason)] if isinstance(event, TransactionFailed) else []
    got = int.from_bytes(event.data, "big") if isinstance(event, ReadCompleted) else None
    report(kind="tx", at=time.monotonic(), started=started, sent=sent, failed=failed,
           ok=got == expected)
host.close()
report(kind="done")
"""


# Transactions after the pause that show the host went on.
ENOUGH = 20


def transactions_after(log: Path, mark: int) -> int:
    """Transactions the host's log reports after its first ``mark`` bytes."""
    return log.read_bytes()[mark:].count(b'"kind": "tx"')


@pytest.mark.parametrize("depth", [1, 16])
@pytest.mark.process
def test_a_stopped_host_comes_back_without_failures_or_taking_over(
    tmp_path: Path, depth: int
) -> None:
    config = BusConfig(bus_name("pause"))
    with LaunchedBus(config, 2, root=tmp_path, node_arguments=ARGS) as bus:
        bus.wait_members()
        log = tmp_path / "host.jsonl"
        with open(log, "w") as out:  # a file never blocks the host as a full pipe would
            host = subprocess.Popen(
                [sys.executable, "-c", HOST_PROGRAM, config.name, str(depth)], stdout=out
            )
        try:
            # Stop the host in the middle of its traffic, and continue it once the
            # bus has dropped it (a lease without a heartbeat from it).
            wait_until(lambda: '"kind": "tx"' in log.read_text(), timeout=30)
            os.kill(host.pid, signal.SIGSTOP)
            wait_hosts_dropped(bus.member_config)
            resumed, mark = time.monotonic(), log.stat().st_size
            os.kill(host.pid, signal.SIGCONT)
            # Enough traffic after the pause to judge it, then the host's end.
            wait_until(lambda: transactions_after(log, mark) >= 2 * ENOUGH, timeout=30)
            os.kill(host.pid, signal.SIGUSR1)
            host.wait(30)
            output = log.read_text()
        finally:
            if host.poll() is None:
                host.kill()
                host.wait()
    assert wait_until_gone(config.name) == []
    lines = [json.loads(line) for line in output.splitlines()]
    assert lines[-1]["kind"] == "done"
    ready = lines[0]
    assert ready["kind"] == "ready" and ready["phy"] == 2
    transactions = [line for line in lines if line["kind"] == "tx"]
    after = [t for t in transactions if t["at"] > resumed]
    assert len(after) > ENOUGH, "the host did not go on after the pause"
    resets = [line for line in lines if line["kind"] == "reset"]
    # A request the stop caught before it went out leaves in the old generation,
    # after the bus dropped the host: no answer can come, and the documented end
    # is bus_reset. Every other read, outstanding during the pause or started
    # after it, must complete with its value.
    caught = [t for t in transactions if t["started"] < resumed < t["sent"]]
    failures = [t for t in transactions if (t["failed"] or not t["ok"]) and t not in caught]
    assert failures == [], (resets, resumed)
    assert all(t["ok"] or t["failed"] == ["bus_reset"] for t in caught), caught
    # Back on the bus it rejoins as what it is: the root, behind both nodes.
    assert resets, "the host was dropped while stopped: it must have rejoined"
    assert {r["phy"] for r in resets} == {2}
