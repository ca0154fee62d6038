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

from bus_support import bus_name, wait_until_gone

from fw1394.transport.config import BusConfig
from fw1394.transport.launch import LaunchedBus

ARGS = ("--heartbeat", "0.1", "--lease", "1.0")

# A host in its own process, doing one write-then-read-back after another and
# printing every outcome and every bus reset it took part in as JSON lines.
HOST_PROGRAM = r"""
import json, sys, time
from fw1394.engine import ReadCompleted, TransactionFailed
from fw1394.transport.bus_host import BusHost
from fw1394.transport.config import BusConfig
from fw1394.transport.membership import Timing

name, seconds = sys.argv[1], float(sys.argv[2])
host = BusHost(BusConfig(name), timing=Timing(heartbeat=0.1, lease=1.0),
               ack_timeout=0.3, split_timeout=0.3)
seen = 0
def report(**fields):
    print(json.dumps(fields), flush=True)
host.wait_ready()
nodes = [phy for phy, _ in host.nodes()]
report(kind="ready", phy=host.phy_id, nodes=nodes)
limit, value = time.monotonic() + seconds, 0
while time.monotonic() < limit:
    value += 1
    node = nodes[value % len(nodes)]
    written = host.wait(host.start_write_quadlet(node, 0x40, value))
    event = host.wait(host.start_read_quadlet(node, 0x40))
    for change in host.resets[seen:]:
        report(kind="reset", phy=change.phy_id, generation=change.generation)
    seen = len(host.resets)
    failed = [str(e.reason) for e in (written, event) if isinstance(e, TransactionFailed)]
    got = int.from_bytes(event.data, "big") if isinstance(event, ReadCompleted) else None
    report(kind="tx", at=time.monotonic(), failed=failed, ok=got == value)
host.close()
report(kind="done")
"""


def test_a_stopped_host_comes_back_without_failures_or_taking_over(tmp_path: Path) -> None:
    config = BusConfig(bus_name("pause"))
    with LaunchedBus(config, 2, root=tmp_path, node_arguments=ARGS) as bus:
        bus.wait_members()
        host = subprocess.Popen(
            [sys.executable, "-c", HOST_PROGRAM, config.name, "7"],
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            time.sleep(2.0)
            os.kill(host.pid, signal.SIGSTOP)
            time.sleep(3.0)  # three leases: the bus drops the host meanwhile
            resumed = time.monotonic()
            os.kill(host.pid, signal.SIGCONT)
            output, _ = host.communicate(timeout=30)
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
    assert len(after) > 20, "the host did not go on after the pause"
    assert [t for t in transactions if t["failed"] or not t["ok"]] == []
    # Back on the bus it rejoins as what it is: the root, behind both nodes.
    resets = [line for line in lines if line["kind"] == "reset"]
    assert resets, "the host was dropped while stopped: it must have rejoined"
    assert {r["phy"] for r in resets} == {2}
