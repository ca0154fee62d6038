"""The example cocotb test of docs/rtl.md, run as written with cocotb's runner."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.rtl.simulation import missing_tools

DOC = Path(__file__).parents[2] / "docs" / "rtl.md"
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]


def _blocks() -> dict[str, str]:
    """The documentation's Python blocks, by the file name on their first line."""
    blocks = re.findall(r"```python\n# (\S+\.py)\n(.*?)```", DOC.read_text(), re.DOTALL)
    return {name: code for name, code in blocks}


def test_the_documented_cocotb_example_runs(tmp_path: Path) -> None:
    blocks = _blocks()
    assert {"test_my_link.py", "run_my_link.py"} <= set(blocks)
    for name in ("test_my_link.py", "run_my_link.py"):
        (tmp_path / name).write_text(blocks[name])
    done = subprocess.run(
        [sys.executable, "run_my_link.py"], cwd=tmp_path, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stdout[-3000:] + done.stderr[-3000:]
    assert "a_write_reads_back_at_every_speed" in done.stdout + done.stderr
