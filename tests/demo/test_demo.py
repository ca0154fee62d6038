"""``fw1394 demo`` end to end, as the README runs it: real processes, a real bus."""

from __future__ import annotations

import json
import math
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bus_support import processes_mentioning

from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.demo.run import trajectory


def trajectory_rms(axis: int, seconds: float) -> float:
    target = trajectory(axis)
    samples = [target(i / 1000) - ENCODER_MIDPOINT for i in range(round(seconds * 1000))]
    return math.sqrt(sum(v * v for v in samples) / len(samples))


@pytest.mark.process
@pytest.mark.slow
def test_demo_runs_servos_plots_and_cleans_up(tmp_path: Path) -> None:
    plot = tmp_path / "demo.png"
    started = time.monotonic()
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "fw1394.cli.main",
            "demo",
            "--seconds",
            "1.5",
            "--json",
            "--plot",
            str(plot),
        ],
        capture_output=True,
        text=True,
        timeout=90,
        cwd=tmp_path,
    )
    elapsed = time.monotonic() - started
    assert result.returncode == 0, result.stderr
    numbers = json.loads(result.stdout)
    # The loop ran on both boards for the whole time, close to its rate.
    assert numbers["seconds"] >= 1.5
    assert numbers["cycles"] > 300
    assert len(numbers["tracking_rms_counts"]) == 11
    # A broken loop (no motion, wrong sign, wrong axis) leaves an error as large as
    # the trajectory itself; a working one, even slowed by a loaded machine, far less.
    for axis, error in enumerate(numbers["tracking_rms_counts"]):
        assert error < 0.8 * trajectory_rms(axis, numbers["seconds"]), (axis, error)
    assert plot.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # The tap recorded the run, and the dissector saw the thesis board's behaviour:
    # block reads answered in the same tenure, block writes completed by their ack.
    traffic = numbers["traffic"]
    assert traffic["errors"]["total"] == 0
    assert traffic["transactions"]["concatenated"] > 100
    assert traffic["transactions"]["unified"] > 100
    assert "split" not in traffic["transactions"]
    bus = numbers["bus"]
    assert not processes_mentioning(bus), "demo left processes behind"
    print(f"\ndemo: {numbers['rate_hz']} Hz, {elapsed:.1f} s wall")


@pytest.mark.process
@pytest.mark.parametrize("spelling", ["--duration", "--seconds"])
def test_demo_rejects_bad_arguments(spelling: str) -> None:
    result = subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", "demo", spelling, "-1"],
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert result.returncode == 2
    assert result.stderr.strip().startswith("fw1394: error: --duration -1")
