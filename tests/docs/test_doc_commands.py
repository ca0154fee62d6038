"""The docs' command lines that need no bus, run as they are written.

Every line of a fenced block in ``docs/`` that starts with ``fw1394 decode``,
``encode``, ``dissect`` or ``wireshark-dissector`` runs in a directory that
holds the files the docs name (a bus trace as ``trace.pcapng``, Eth1394 UDP
traffic as ``boards.pcap``, the kernel log of ``examples/``). Synopsis lines
(with ``[OPTIONS]`` or ``FILE|-``) are usage, not commands, and are left out.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.trace_writer import write_trace

ROOT = Path(__file__).resolve().parents[2]
OFFLINE = re.compile(r"^fw1394 (decode|encode|dissect|wireshark-dissector)\b")
SYNOPSIS = re.compile(r"\[|FILE\||\.\.\.|\bFILE\b|\bEXPR\b")


def command_lines() -> list[tuple[str, str]]:
    found = []
    for doc in sorted((ROOT / "docs").rglob("*.md")):
        blocks = re.findall(r"```[a-z]*\n(.*?)```", doc.read_text(encoding="utf-8"), re.DOTALL)
        for block in blocks:
            for line in block.splitlines():
                command = line.split("  #", 1)[0].strip()
                if OFFLINE.match(command) and not SYNOPSIS.search(command):
                    found.append((doc.relative_to(ROOT).as_posix(), command))
    return found


COMMANDS = command_lines()


@pytest.fixture(scope="module")
def workdir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    where = tmp_path_factory.mktemp("docs")
    scenario = Scenario(busy_every=13, lost_every=17, corrupt_every=19)
    write_trace(str(where / "trace.pcapng"), simulate(400, scenario))
    write_eth1394_sample(str(where / "boards.pcap"))
    shutil.copy(ROOT / "examples" / "dmesg.txt", where / "dmesg.txt")
    shutil.copytree(ROOT / "examples", where / "examples")
    return where


def test_the_docs_have_commands_to_run() -> None:
    assert len(COMMANDS) >= 5
    assert any("dissect.md" in doc for doc, _ in COMMANDS)


@pytest.mark.process
@pytest.mark.parametrize(("doc", "command"), COMMANDS, ids=[c for _, c in COMMANDS])
def test_a_doc_command_runs(workdir: Path, doc: str, command: str) -> None:
    binaries = str(Path(sys.executable).parent)
    env = {**os.environ, "PATH": f"{binaries}:{os.environ['PATH']}"}
    result = subprocess.run(
        ["bash", "-c", f"set -o pipefail; {command} > /dev/null"],
        cwd=workdir,
        env=env,
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "Traceback" not in result.stderr, (doc, command, result.stderr)
    assert result.returncode == 0, (doc, command, result.stderr)
