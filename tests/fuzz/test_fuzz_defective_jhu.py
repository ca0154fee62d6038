"""One campaign without a model finds every defect planted in an independent Eth1394 board.

The board is ``jhu_defective_node.py``, written from the JHU Eth1394
description alone (registers by quadlet index, no fw1394 code), with four
defects: a write to register 0x21 that also overwrites 0x31, packets for node
5 taken as its own, a wedge after a 4096-byte block read, and register 0x1f
losing bit 0 of values with bit 31 set. No ``--model``: the register oracle
learns from the board's own answers. Each defect must come out of one
3,000-case campaign with ``--restart`` as its own finding, shrunk, and
reproduced by ``fuzz replay`` on a fresh board.
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.fuzz.findings import load

NODE = Path(__file__).with_name("jhu_defective_node.py")
DEFECTS = ("--corrupt", "--other-node", "--wedge", "--stuck-bit")
#: Each planted defect as the campaign must report it.
EXPECTED = {
    ("state", "learned:changed"),  # 0x21 overwrites 0x31
    ("silence", "other-node:read:response"),  # node 5 taken as its own
    ("liveness", "valid-read-unanswered"),  # the wedge
    ("state", "learned:not-read-back"),  # register 0x1f loses bit 0
}
NODE_LIFETIME = 300

pytestmark = [pytest.mark.slow, pytest.mark.process]


def free_port() -> int:
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def restart_script(directory: Path, port: int) -> Path:
    """Stops the board it started last (waits until it is gone), starts a fresh one."""
    pidfile = directory / "node.pid"
    script = directory / "restart-node.sh"
    script.write_text(
        "#!/bin/sh\n"
        f'if [ -f "{pidfile}" ]; then\n'
        f'  old=$(cat "{pidfile}"); kill "$old" 2>/dev/null\n'
        '  while [ "$(cut -d" " -f3 /proc/$old/stat 2>/dev/null || echo Z)" != Z ]; do\n'
        "    sleep 0.01\n"
        "  done\n"
        "fi\n"
        f'"{sys.executable}" "{NODE}" {port} {NODE_LIFETIME} {" ".join(DEFECTS)} >/dev/null &\n'
        f'echo $! > "{pidfile}"\n'
        'echo "node started as process $!"\n'
    )
    script.chmod(0o755)
    return script


def cli(*args: str) -> subprocess.CompletedProcess[str]:
    command = [sys.executable, "-m", "fw1394.cli.main", "fuzz", *args]
    return subprocess.run(command, capture_output=True, text=True, timeout=900, check=False)


def test_one_campaign_finds_shrinks_and_replays_every_planted_defect(tmp_path: Path) -> None:
    port = free_port()
    restart = restart_script(tmp_path, port)
    subprocess.run([str(restart)], check=True, stdout=subprocess.DEVNULL)
    found = tmp_path / "found"
    try:
        result = cli(
            "run", f"udp:127.0.0.1:{port}", "--eth1394", "--restart", str(restart),
            "--max-cases", "3000", "--state-every", "16", "--history", "1024",
            "--timeout", "0.2", "--dead-after", "10", "--shrink-budget", "25",
            "--findings", str(found), "--json",
        )  # fmt: skip
        assert result.returncode == 1, result.stderr
        report = json.loads(result.stdout)
        assert report["cases"] == 3000, report["stopped"]
        findings = {f.key: f for _, f in load(found)}
        assert set(findings) >= EXPECTED, sorted(findings)
        for key in EXPECTED:
            assert findings[key].reproduced and findings[key].shrunk, key
        # The findings name what went wrong where.
        assert "register 0x31" in findings[("state", "learned:changed")].observed
        assert "register 0x1f" in findings[("state", "learned:not-read-back")].observed
        other = findings[("silence", "other-node:read:response")]
        cases = [entry for entry in other.stream if entry.role == "case"]
        assert len(cases) == 1 and cases[0].raw[1] & 0x3F == 5  # node 5, quadlet 0's low bits

        replayed = cli("replay", str(found), "--restart", str(restart), "--json")
        lines = [json.loads(line) for line in replayed.stdout.splitlines()]
        reproduced = {(r["oracle"], r["signature"]) for r in lines if r["reproduced"]}
        assert reproduced >= EXPECTED, replayed.stdout + replayed.stderr
    finally:
        with contextlib.suppress(ProcessLookupError, FileNotFoundError, ValueError):
            os.kill(int((tmp_path / "node.pid").read_text()), signal.SIGTERM)
