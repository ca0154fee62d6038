"""Bad input to the fuzz, jhu and libraw1394 commands: one line on stderr, status 2.

Their library errors reach :func:`fw1394.cli.main.main` unwrapped; what the
command line adds is only the option, file or port the message would
otherwise not name. Each case checks the line names what the user typed.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.cli.main import main


def one_line_error(argv: list[str], capsys: pytest.CaptureFixture[str]) -> str:
    assert main(argv) == 2
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err.startswith("fw1394: error: ") and captured.err.count("\n") == 1
    return captured.err


@pytest.mark.parametrize(
    ("argv", "named"),
    [
        (["fuzz", "run", "inproc:nope", "--max-cases", "5"], "'nope'"),
        (["fuzz", "run", "inproc:memory", "--max-cases", "5", "--plot", "run.xyz"], "run.xyz"),
        (["fuzz", "serve", "memory", "--listen", "10.1.2.3:5"], "10.1.2.3"),
        (["fuzz", "serve", "memory", "--defect", "no-such-bug"], "'no-such-bug'"),
        (["jhu", "serve", "--eth1394", "10.0.0.1"], "10.0.0.1"),
        (["jhu", "serve", "--board-ids", "a,b", "--eth1394", "127.0.0.1:11394"], "a,b"),
        (["jhu", "serve", "--board-ids", "1,1", "--eth1394", "127.0.0.1:11394"], "[1, 1]"),
        (["jhu", "scan", "-p", "udp:10.0.0.1"], "10.0.0.1"),
        (["run", "--name", "bad/name", "--", "true"], "'bad/name'"),
    ],
)  # fmt: skip
def test_bad_input_is_one_line_naming_it(
    argv: list[str],
    named: str,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
) -> None:
    monkeypatch.chdir(tmp_path)  # the fuzz campaigns' default findings directory
    assert named in one_line_error(argv, capsys)


def test_findings_kept_are_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    findings = tmp_path / "found"
    findings.mkdir()
    (findings / "000-planted.json").write_text("{}")
    argv = ["fuzz", "run", "inproc:memory", "--max-cases", "5", "--findings", str(findings)]
    assert f"{findings} already holds findings" in one_line_error(argv, capsys)


@pytest.mark.process
@pytest.mark.skipif(
    os.geteuid() != 0 or not shutil.which("unshare"),
    reason="needs root and unshare for a network namespace (its loopback down)",
)
def test_a_host_with_no_loopback_to_send_on_names_the_port() -> None:
    # A fresh namespace's lo is down: the client's socket options fail with EADDRNOTAVAIL.
    done = subprocess.run(
        ["unshare", "-n", sys.executable, "-m", "fw1394.cli.main",
         "jhu", "scan", "-p", "udp:127.0.0.1:11394"],
        capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert (done.returncode, done.stdout) == (2, "")
    assert done.stderr.splitlines() == [
        "fw1394: error: -p udp:127.0.0.1:11394: Cannot assign requested address"
    ]
