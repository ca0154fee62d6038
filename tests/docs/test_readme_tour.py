"""The README's tour, run as it is written: its sh block, in order, in a fresh
directory holding only ``examples/`` (what a clone's root has for it).

It runs in a network namespace of its own (``unshare -n``, loopback only), so
its bus "default" and its UDP ports meet no other test's. Every step of the tour
bounds its own duration; the whole is bounded here too.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
pytestmark = [
    pytest.mark.process,
    pytest.mark.netns,
    pytest.mark.slow,
    # The tour's own steps take minutes: a bus up and down, a 20 s campaign, the bench.
    pytest.mark.timeout(1200),
    pytest.mark.skipif(
        os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("ip"),
        reason="needs root, unshare and iproute2 for a network namespace of its own",
    ),
]


def tour_script() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## A short tour of the CLI", 1)[1]
    found = re.search(r"```sh\n(.*?)```", section, re.DOTALL)
    assert found is not None, "the README's tour has no sh block"
    return found.group(1)


def test_the_tour_runs_as_written(tmp_path: Path) -> None:
    shutil.copytree(ROOT / "examples", tmp_path / "examples")
    (tmp_path / "tour.sh").write_text("set -eu\n" + tour_script(), encoding="utf-8")
    runtime = tmp_path / "runtime"
    runtime.mkdir(mode=0o700)
    binaries = str(Path(sys.executable).parent)
    env = {
        **os.environ,
        "PATH": f"{binaries}:{os.environ['PATH']}",
        "XDG_RUNTIME_DIR": str(runtime),
    }
    command = ["unshare", "-n", "sh", "-c", "ip link set lo up && exec bash -x tour.sh"]
    # A hung step fails the test instead of stalling it.
    result = subprocess.run(
        command, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=900
    )
    tail = result.stderr[-4000:]
    assert result.returncode == 0, tail
    assert "Traceback" not in result.stdout + result.stderr
    out = result.stdout
    assert "read_quadlet_request" in out  # the first decode
    assert (tmp_path / "trace.pcapng").stat().st_size > 0
    assert (tmp_path / "latency.png").read_bytes()[:4] == b"\x89PNG"
    assert (tmp_path / "fw1394.lua").read_text().startswith("-- fw1394.lua")
    assert (tmp_path / "fuzz-findings" / "report.json").exists()
