"""The servo loop's process asks the kernel for precise timers (Linux's timer slack)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ASK = """
import sys
from fw1394.demo.pacing import tighten_timer_slack
print(tighten_timer_slack(int(sys.argv[1])))
print(open("/proc/self/timerslack_ns").read().strip())
"""


@pytest.mark.process
@pytest.mark.skipif(
    not Path("/proc/self/timerslack_ns").exists(), reason="needs Linux's /proc/PID/timerslack_ns"
)
@pytest.mark.parametrize("nanoseconds", [1000, 2500])
def test_the_kernel_keeps_the_slack_asked_for(nanoseconds: int) -> None:
    # The kernel's default is 50 µs; what /proc reads back is the kernel's own record.
    out = subprocess.run(
        [sys.executable, "-c", ASK, str(nanoseconds)],
        capture_output=True,
        text=True,
        check=True,
        timeout=60,
    ).stdout.split()
    assert out == ["True", str(nanoseconds)]
