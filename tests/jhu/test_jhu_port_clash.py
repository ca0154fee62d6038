"""No silent port clash: ``jhu serve`` and ``fuzz serve`` refuse a UDP port in use and name
its holder, unless ``--reuse-port`` asks to share it.

The holder is a plain Python socket in a process of its own, written here (not fw1394
code), bound with SO_REUSEADDR: the option that let a second server start on the same
address without a word.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest

from fw1394.transport.udp_ports import PortInUseError, refuse_taken_port, udp_socket_inodes

PORT = 24_000 + os.getpid() % 5_000

HOLDER = """
import socket, sys, time
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
s.bind((sys.argv[1], int(sys.argv[2])))
print("bound", flush=True)
time.sleep(60)
"""


def hold(host: str, port: int) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", HOLDER, host, str(port), "port-holder-marker"],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None
    assert process.stdout.readline().strip() == "bound"
    return process


@pytest.fixture
def holder() -> Iterator[subprocess.Popen[str]]:
    process = hold("127.0.0.1", PORT)
    try:
        yield process
    finally:
        process.kill()
        process.wait(10)


def fw1394(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", *args],
        capture_output=True,
        text=True,
        timeout=120,
    )


@pytest.mark.process
def test_jhu_serve_refuses_a_held_port_naming_the_holder(holder: subprocess.Popen[str]) -> None:
    result = fw1394("jhu", "serve", "--eth1394", f"127.0.0.1:{PORT}", "--duration", "0.5")
    assert result.returncode == 2
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert f"pid {holder.pid}" in lines[0]
    assert "(python3 -c import socket" in lines[0] or "(python -c import socket" in lines[0]
    assert "--reuse-port" in lines[0]
    assert "Traceback" not in result.stderr


@pytest.mark.process
def test_jhu_serve_shares_the_port_when_asked(holder: subprocess.Popen[str]) -> None:
    result = fw1394(
        "jhu", "serve", "--eth1394", f"127.0.0.1:{PORT}", "--duration", "0.3", "--reuse-port"
    )
    assert result.returncode == 0, result.stderr
    assert "QLA boards" in result.stderr


@pytest.mark.process
def test_a_wildcard_holder_clashes_with_loopback() -> None:
    process = hold("0.0.0.0", PORT + 1)
    try:
        with pytest.raises(PortInUseError, match=f"pid {process.pid}"):
            refuse_taken_port("127.0.0.1", PORT + 1)
        refuse_taken_port("127.0.0.1", PORT + 2)  # a free port passes
    finally:
        process.kill()
        process.wait(10)


@pytest.mark.process
def test_fuzz_serve_names_the_holder(holder: subprocess.Popen[str]) -> None:
    result = fw1394("fuzz", "serve", "memory", "--listen", f"127.0.0.1:{PORT}", "--duration", "1")
    assert result.returncode == 2
    assert f"pid {holder.pid}" in result.stderr
    assert len(result.stderr.strip().splitlines()) == 1
    assert "Traceback" not in result.stderr


def test_proc_net_udp_rows_by_address_and_port(tmp_path: Path) -> None:
    # /proc/net/udp: local address as the in-memory u32 in hex, port in hex, inode 10th.
    def row(address: str, port: int, inode: int) -> str:
        packed = int.from_bytes(socket.inet_aton(address), sys.byteorder)
        return (
            f"  1: {packed:08X}:{port:04X} 00000000:0000 07 00000000:00000000 "
            f"00:00000000 00000000     0        0 {inode} 2 0000000000000000 0"
        )

    table = tmp_path / "udp"
    header = "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  "
    table.write_text(
        "\n".join(
            [
                header + "timeout inode ref pointer drops",
                row("127.0.0.1", 1394, 101),
                row("127.255.255.255", 1394, 102),
                row("0.0.0.0", 1394, 103),
                row("127.0.0.1", 1395, 104),
            ]
        )
        + "\n"
    )
    assert udp_socket_inodes("127.0.0.1", 1394, table) == {101, 103}
    assert udp_socket_inodes("0.0.0.0", 1394, table) == {101, 102, 103}
    assert udp_socket_inodes("127.0.0.2", 1395, table) == set()
