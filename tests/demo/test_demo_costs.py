"""The demo's cost figures are measured, not assumed: they agree with its capture.

The host counts every transaction it starts; the capture, a separate process
tapping the bus, sees every request on the wire, and the dissector counts them
by tcode. Both counts must be equal, which also proves the capture listened
before the first transaction and stopped after the last, even when a capture
file from an earlier run is still there.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from fw1394.demo.report import summary, traffic
from fw1394.demo.run import _tap, run_demo
from fw1394.transport.sansio.config import BusConfig

#: The block type that opens every pcapng file.
PCAPNG_SECTION = b"\x0a\x0d\x0d\x0a"


@pytest.mark.process
@pytest.mark.slow
def test_summary_counts_match_the_capture_and_every_process_is_measured(tmp_path: Path) -> None:
    capture = tmp_path / "demo.pcapng"
    capture.write_bytes(PCAPNG_SECTION + bytes(60))  # an earlier run's file
    numbers = summary(run_demo(1.5, capture=capture))
    tcodes = traffic(capture)["tcodes"]
    requests = {kind: n for kind, n in tcodes.items() if kind.endswith("_request")}
    assert numbers["transactions_by_kind"] == requests
    # The servo loop itself: one block read and one block write per board and cycle.
    servo = numbers["servo_transactions_by_kind"]
    cycles, lost = numbers["cycles"], numbers["bus_resets"]
    for kind in ("read_block_request", "write_block_request"):
        assert 2 * cycles <= servo[kind] <= 2 * (cycles + lost)
    costs = numbers["per_cycle_by_process"]
    assert {"host", "node snake2010", "node snake2010-ztheta", "capture"} <= set(costs)
    for name in ("host", "node snake2010", "node snake2010-ztheta", "capture"):
        # Each of them works on every cycle; no process can use more than the wall time.
        assert 0 < costs[name]["cpu_us"] * numbers["cycles"] <= numbers["seconds"] * 1e6


@pytest.mark.process
def test_the_demo_waits_for_its_own_capture_not_an_earlier_file(tmp_path: Path) -> None:
    capture = tmp_path / "demo.pcapng"
    capture.write_bytes(b"an earlier run's capture")
    with _tap(BusConfig(name=f"tap-{os.getpid()}"), capture) as tap:
        assert tap is not None
        # Traffic may start now: the new capture's header is on disk, so its tap listens.
        assert capture.read_bytes()[:4] == PCAPNG_SECTION
