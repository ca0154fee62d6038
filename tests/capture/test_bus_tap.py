"""The bus tap on a busy bus: every frame recorded, without a wake-up per frame."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
import time

import pytest
from bus_support import LaunchBus

from fw1394.capture.formats.bus_tap import BATCH_INTERVAL
from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.membership import Timing

READS = 400
#: Between reads: long enough for a tap that slept in recv to fall asleep
#: after each read, short enough that a batching tap sleeps through several.
GAP = 0.0003

# The tap runs in a process of its own so that its context switches are its own
# (in a thread of the test's process, waits for the GIL would count too).
TAP = textwrap.dedent(
    """
    import json, sys, time
    from collections import Counter
    from fw1394.capture.formats.bus_tap import BusTap

    def switches():
        for line in open("/proc/thread-self/status"):
            if line.startswith("voluntary_ctxt_switches"):
                return int(line.split()[1])

    with BusTap(sys.argv[1], ack_wait=0.2) as tap:
        print("ready", flush=True)
        kinds, first, last = Counter(), None, None
        while (record := tap.receive(1.0)) is not None:
            last = time.monotonic(), switches()
            first = first or last
            kinds[record.record_type.name] += 1
            if record.record_type.name == "async_packet":
                kinds["acked"] += record.ack is not None
    seconds, wakeups = last[0] - first[0], last[1] - first[1]
    print(json.dumps({"kinds": kinds, "seconds": seconds, "wakeups": wakeups}))
    """
)


@pytest.mark.process
def test_tap_records_a_busy_bus_in_batches(launch_bus: LaunchBus) -> None:
    bus = launch_bus(1, tag="tapbatch")
    timing = Timing(heartbeat=0.1, lease=2.0)
    with BusPort(bus.config, timing=timing, ack_timeout=1.0) as port:
        port.nodes()
        tap = subprocess.Popen(
            [sys.executable, "-c", TAP, bus.config.name], stdout=subprocess.PIPE, text=True
        )
        try:
            assert tap.stdout is not None
            assert tap.stdout.readline() == "ready\n"
            for offset in range(READS):
                port.read_quadlet(0, 4 * (offset % 16))
                time.sleep(GAP)
            out, _ = tap.communicate(timeout=30)
        finally:
            tap.kill()
    report = json.loads(out)
    kinds = report["kinds"]
    # Each read: its request, the ack with the response concatenated (two
    # records), and the host's ack of the response; every packet with its ack.
    assert kinds["async_packet"] == 2 * READS
    assert kinds["ack"] == 2 * READS
    assert kinds["acked"] == 2 * READS
    # While the bus is busy the tap wakes once per batch, not once per read (a
    # tap that slept in recv would, on a machine fast enough to do a read in
    # less than BATCH_INTERVAL).
    batches = report["seconds"] / BATCH_INTERVAL
    assert report["wakeups"] <= 1.2 * batches + 30
