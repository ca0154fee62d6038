"""``fw1394 jhu scan -v`` prints the host library's lines; SIGTERM ends ``jhu serve`` at once.

The expected lines are the library's own (mechatronics-software 2.2.0,
EthUdpPort::InitNodes, BasePort::ScanNodes and BasePort::SetDefaultProtocol;
jhu-eth1394.md §4.9 lists the steps): a real server process on loopback, the
real CLI as a subprocess.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest

from fw1394.jhu.scan import ScannedBoard, default_protocol, git_suffix

# Two ports per test process (parallel workers each have their own pid).
PORT = 20_000 + 2 * (os.getpid() % 5_000)


def serve(*options: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-m", "fw1394.cli.main", "jhu", "serve", *options],
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stderr is not None
    ready = process.stderr.readline()
    assert "QLA boards" in ready, ready
    return process


def scan_log(port: int) -> list[str]:
    result = subprocess.run(
        [
            sys.executable,
            "-m",
            "fw1394.cli.main",
            "jhu",
            "scan",
            "-v",
            "-p",
            f"udp:127.0.0.1:{port}",
            # Ten times the library's 20 ms: each of the 14 absent nodes waits it.
            "--receive-timeout",
            "0.2",
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0, result.stderr
    return result.stderr.splitlines()


@pytest.mark.process
def test_scan_prints_the_library_lines_in_bridge_mode() -> None:
    server = serve("--boards", "2", "--firmware", "8", "--eth1394", f"127.0.0.1:{PORT}")
    try:
        lines = scan_log(PORT)
    finally:
        server.send_signal(signal.SIGTERM)
        server.wait(timeout=30)
    expected_in_order = [
        "InitNodes: Firewire bus generation = 0",
        "InitNodes: found hub board: 0",
        "InitNodes: hub board has Firmware Rev 8, using Ethernet/Firewire bridge",
        "BasePort::ScanNodes: building node map for 16 nodes:",
        "  Node 0, BoardId = 0, FPGA_V3, Hardware = QLA1, Firmware Version = 8",
        "  Node 1, BoardId = 1, FPGA_V3, Hardware = QLA1, Firmware Version = 8",
        "BasePort::ScanNodes: found 2 boards",
        "BasePort::SetDefaultProtocol: all nodes broadcast capable and support shorter wait",
        "Initialization done",
    ]
    positions = [lines.index(line) for line in expected_in_order]
    assert positions == sorted(positions), lines


@pytest.mark.parametrize(
    ("revisions", "text", "broadcast"),
    [
        ([8, 9], "all nodes broadcast capable and support shorter wait", True),
        ([6], "all nodes broadcast capable and support shorter wait", True),
        ([4, 5], "all nodes broadcast capable and do not support shorter wait", True),
        ([4, 6], "all nodes broadcast capable and some support shorter wait", True),
        ([7, 8], "all nodes broadcast capable, but disabled due to mix of firmware", False),
        ([10], "all nodes broadcast capable, but disabled due to mix of firmware", False),
        ([3, 8], None, False),
    ],
)
def test_set_default_protocol_lines(
    revisions: list[int], text: str | None, broadcast: bool
) -> None:
    said: list[str] = []
    boards = [ScannedBoard(n, n, 0x514C4131, rev, 3, 0) for n, rev in enumerate(revisions)]
    protocol = default_protocol(boards, said.append)
    assert said == ([] if text is None else [f"BasePort::SetDefaultProtocol: {text}"])
    assert (protocol.value == "broadcast-write") is broadcast


def test_git_description_suffix() -> None:
    assert git_suffix(0) == ""
    assert git_suffix(0x1234567_0) == ""  # a release: nothing shown
    assert git_suffix(0x1234567_4) == "+ (git-1234567)"
    assert git_suffix(0x00000AB_9) == "- (git-00000ab*)"
    assert git_suffix(0x1234567_2) == "? (git-1234567)"


@pytest.mark.process
def test_sigterm_ends_the_server_at_once() -> None:
    server = serve("--eth1394", f"127.0.0.1:{PORT + 1}")
    time.sleep(0.3)
    started = time.monotonic()
    server.send_signal(signal.SIGTERM)
    code = server.wait(timeout=30)
    elapsed = time.monotonic() - started
    assert server.stderr is not None
    tail = server.stderr.read()
    assert code == 0
    assert "stopped after 0 requests" in tail
    # 0.2 s is the goal (a few ms when the machine is idle); the bound allows for load.
    assert elapsed < 1.0
