"""Campaigns that outlive their target: a wedging node brought back by ``--restart``.

The node is ``eth1394_node.py``, written from the 1394 and Eth1394 formats
alone (no fw1394 code), started as a process on 127.0.0.1 by a shell script
that is also the restart command: it stops the node it started last, waits
until it has gone, and starts a fresh one. Four planted violations, one of
them a wedge after a long block write, must all come out of one campaign as
distinct findings, shrunk on fresh nodes, and reproduce on replay.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from fw1394.fuzz.findings import load

NODE = Path(__file__).with_name("eth1394_node.py")
VIOLATIONS = ("--wedge", "--other-nodes", "--bad-crc-reads", "--side-effect")
#: What each planted violation must be reported as.
EXPECTED = {
    ("silence", "other-node:read:response"),
    ("silence", "bad-header-crc:read:response"),
    ("liveness", "valid-read-unanswered"),
    ("state", "sweep-changed@MEMORY:data"),
}
#: Seconds a node process lives at most (it stops by itself).
NODE_LIFETIME = 120

pytestmark = [pytest.mark.slow, pytest.mark.process]


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def restart_script(directory: Path, port: int, node: str = "") -> Path:
    """A script that stops the node it started last and starts ``node`` (default:
    the independent node with every violation) listening on ``port``."""
    node = node or f'"{NODE}" {port} {NODE_LIFETIME} {" ".join(VIOLATIONS)}'
    pidfile = directory / "node.pid"
    script = directory / "restart-node.sh"
    script.write_text(
        "#!/bin/sh\n"
        f'if [ -f "{pidfile}" ]; then\n'
        f'  old=$(cat "{pidfile}"); kill "$old" 2>/dev/null\n'
        # Gone once it is a zombie: its socket is closed, and reaping may take a while.
        '  while [ "$(cut -d" " -f3 /proc/$old/stat 2>/dev/null || echo Z)" != Z ]; do\n'
        "    sleep 0.01\n"
        "  done\n"
        "fi\n"
        f'"{sys.executable}" {node} >/dev/null &\n'
        f'echo $! > "{pidfile}"\n'
        'echo "node started as process $!"\n'
    )
    script.chmod(0o755)
    return script


@pytest.fixture
def node(tmp_path: Path) -> Iterator[tuple[str, str]]:
    """The node's ``udp:`` target and the command that restarts it."""
    port = free_port()
    script = restart_script(tmp_path, port)
    subprocess.run([str(script)], check=True, stdout=subprocess.DEVNULL)
    try:
        yield f"udp:127.0.0.1:{port}", str(script)
    finally:
        pid = int((tmp_path / "node.pid").read_text())
        with contextlib.suppress(ProcessLookupError):
            os.kill(pid, signal.SIGTERM)


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "fw1394.cli.main", "fuzz", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=600, check=False)


def test_one_campaign_finds_shrinks_and_replays_every_violation(
    node: tuple[str, str], tmp_path: Path
) -> None:
    target, restart = node
    found = tmp_path / "found"
    result = cli(
        "run", target, "--eth1394", "--model", "memory", "--restart", restart,
        "--max-cases", "1200", "--state-every", "16", "--history", "128",
        "--timeout", "0.2", "--dead-after", "10", "--shrink-budget", "25",
        "--findings", str(found), "--json",
    )  # fmt: skip
    assert result.returncode == 1, result.stderr
    report = json.loads(result.stdout)
    keys = {(f["oracle"], f["signature"]) for f in report["findings"]}
    assert keys >= EXPECTED, report["findings"]
    assert report["coverage"]["oracles"]["liveness"]["violations"] >= 1
    findings = {f.key: f for _, f in load(found)}
    for key in EXPECTED:
        finding = findings[key]
        assert finding.reproduced and finding.shrunk, key
    # The wedge: shrunk to what sets it off, and the restart that brought the node back.
    wedge = findings[("liveness", "valid-read-unanswered")]
    assert len([e for e in wedge.stream if e.role == "case"]) <= 2
    assert any(len(e.raw) > 2048 for e in wedge.stream if e.role == "case")
    assert wedge.restarts and wedge.restarts[0]["status"] == 0
    assert "node started as process" in wedge.restarts[0]["output"]
    # The side effect: both registers named.
    side = findings[("state", "sweep-changed@MEMORY:data")]
    assert "register 0x24" in side.observed and "0x10" in side.observed
    # Each silence finding is one packet.
    for key in EXPECTED:
        if key[0] == "silence":
            assert [e.role for e in findings[key].stream].count("case") == 1

    replayed = cli("replay", str(found), "--restart", restart, "--json")
    lines = [json.loads(line) for line in replayed.stdout.splitlines()]
    reproduced = {(r["oracle"], r["signature"]) for r in lines if r["reproduced"]}
    assert reproduced >= EXPECTED, replayed.stdout + replayed.stderr
    assert replayed.returncode == 1


def test_a_node_that_never_comes_back_ends_the_run(tmp_path: Path) -> None:
    port = free_port()
    script = restart_script(tmp_path, port)
    subprocess.run([str(script)], check=True, stdout=subprocess.DEVNULL)
    pid = int((tmp_path / "node.pid").read_text())
    try:
        result = cli(
            "run", f"udp:127.0.0.1:{port}", "--eth1394", "--model", "memory",
            "--restart", "echo giving up; exit 3", "--max-cases", "3000",
            "--timeout", "0.2", "--dead-after", "1", "--shrink-budget", "0",
            "--findings", str(tmp_path / "found"), "--json",
        )  # fmt: skip
    finally:
        os.kill(pid, signal.SIGTERM)
    report = json.loads(result.stdout)
    assert report["stopped"].startswith("target gone (no answer within 1.0 s of a restart")
    assert "exit status 3" in report["stopped"] and "giving up" in report["stopped"]
    assert report["cases"] < 3000


def test_a_tunnel_node_is_restarted_after_a_wedge(tmp_path: Path) -> None:
    """fw1394's tunnel framing, against ``fuzz serve`` with a planted wedge."""
    port = free_port()
    serve = (
        f"-m fw1394.cli.main fuzz serve memory --listen 127.0.0.1:{port} "
        f"--defect wedge-after-long-block-write --duration {NODE_LIFETIME}"
    )
    script = restart_script(tmp_path, port, serve)
    subprocess.run([str(script)], check=True, stdout=subprocess.DEVNULL)
    try:
        result = cli(
            "run", f"udp:127.0.0.1:{port}", "--model", "memory", "--restart", str(script),
            "--max-cases", "400", "--timeout", "0.3", "--dead-after", "20",
            "--shrink-budget", "4", "--findings", str(tmp_path / "found"), "--json",
        )  # fmt: skip
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(int((tmp_path / "node.pid").read_text()), signal.SIGTERM)
    report = json.loads(result.stdout)
    assert report["stopped"] == "max-cases" and report["cases"] == 400, report["stopped"]
    wedge = {f.key: f for _, f in load(tmp_path / "found")}[("liveness", "valid-read-unanswered")]
    assert wedge.restarts and wedge.restarts[0]["status"] == 0
    assert any("restarted" in note for note in report["notes"])
