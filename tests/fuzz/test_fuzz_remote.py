"""Remote targets: node processes behind UDP (both framings), an independent node, the bus.

Every process is started with this test process as its parent (it dies with
it) and a time limit of its own, and is stopped in a ``finally``.
"""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from fw1394.fuzz.campaign import run
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.udptarget import UdpTarget

LIMIT = "60"


@contextmanager
def process(*command: str) -> Iterator[tuple[subprocess.Popen[str], str]]:
    """A child process and the first line it prints (the address it listens on)."""
    child = subprocess.Popen(command, stdout=subprocess.PIPE, stdin=subprocess.DEVNULL, text=True)
    try:
        assert child.stdout is not None
        line = child.stdout.readline().strip()
        assert line, f"{command} printed nothing"
        yield child, line
    finally:
        if child.poll() is None:
            child.terminate()
            try:
                child.wait(5)
            except subprocess.TimeoutExpired:
                child.kill()
                child.wait()
        if child.stdout is not None:
            child.stdout.close()


def serve(board: str, *extra: str) -> list[str]:
    return [
        sys.executable, "-m", "fw1394.cli.main", "fuzz", "serve", board,
        "--listen", "127.0.0.1:0", "--duration", LIMIT, "--parent-pid", str(os.getpid()), *extra,
    ]  # fmt: skip


def address(line: str) -> str:
    assert line.startswith("listening on "), line
    return line.removeprefix("listening on ")


def keys(settings: Settings) -> set[tuple[str, str]]:
    return {(f.oracle, f.signature) for f in run(settings).findings}


@pytest.mark.process
def test_tunnel_node_with_a_planted_defect() -> None:
    with process(*serve("memory", "--defect", "answers-other-node")) as (_, line):
        settings = Settings(f"udp:{address(line)}", model="memory", max_cases=400, shrink_budget=5)
        found = keys(settings)
    assert any(o == "silence" and s.startswith("other-node") for o, s in found)


@pytest.mark.process
def test_tunnel_node_without_defects_meets_its_contract() -> None:
    # Plain memory: a board with a clock (the QLA's 30 ms power-up watchdog) lets
    # a loaded machine's stalls show up as state differences from the model.
    with process(*serve("memory")) as (_, line):
        report = run(Settings(f"udp:{address(line)}", model="memory", max_cases=400))
    assert report.findings == []
    assert report.checks["liveness"] >= 400 and report.checks["state"] > 50


@pytest.mark.process
def test_eth1394_node_answering_damaged_reads() -> None:
    with process(*serve("memory", "--eth1394", "--defect", "bad-crc-read-answered")) as (_, line):
        settings = Settings(
            f"udp:{address(line)}", eth1394=True, model="memory", max_cases=400, shrink_budget=5
        )
        found = keys(settings)
    assert any(o == "silence" and ":read:" in s for o, s in found)


@pytest.mark.process
def test_a_crashing_node_process_ends_the_run() -> None:
    with process(*serve("memory", "--defect", "crash-on-empty-block-write")) as (child, line):
        settings = Settings(
            f"udp:{address(line)}", model="memory", max_cases=5000, pid=child.pid, dead_after=0.5
        )
        report = run(settings)
        child.wait(5)
    assert report.stopped.startswith("target gone")
    assert any(f.oracle in ("process", "liveness") for f in report.findings)
    assert report.cases < 5000


#: A node written from the 1394 and Eth1394 documents alone, sharing no code with
#: fw1394: 64 KiB of memory (offsets alias onto it), reads and writes, no locks.
#: Its deliberate bug is the JHU Ethernet path's: it never checks a CRC.
INDEPENDENT_NODE = textwrap.dedent(
    """
    import socket, struct, sys, time

    def crc32(data):
        crc = 0xFFFFFFFF
        for byte in data:
            crc ^= byte << 24
            for _ in range(8):
                crc = (crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1
                crc &= 0xFFFFFFFF
        return crc ^ 0xFFFFFFFF

    memory = bytearray(65536)
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(0.2)
    print("listening on 127.0.0.1:%d" % sock.getsockname()[1], flush=True)
    end = time.monotonic() + float(sys.argv[1])
    while time.monotonic() < end:
        try:
            datagram, peer = sock.recvfrom(65535)
        except socket.timeout:
            continue
        packet = datagram[2:]
        if len(packet) < 16:
            continue
        q0, q1, q2 = struct.unpack(">III", packet[:12])
        destination, tlabel, tcode = q0 >> 16, (q0 >> 10) & 0x3F, (q0 >> 4) & 0xF
        if destination & 0x3F != 0:
            continue
        source, offset = q1 >> 16, ((q1 & 0xFFFF) << 32 | q2) & 0xFFFC

        def response(tcode, last):
            first = source << 16 | tlabel << 10 | tcode << 4
            return struct.pack(">IIII", first, 0xFFC0 << 16, 0, last)

        if tcode == 4:
            body = response(6, int.from_bytes((memory * 2)[offset:offset + 4], "big"))
            sock.sendto(body + struct.pack(">I", crc32(body)) + bytes(8), peer)
        elif tcode == 5 and len(packet) >= 20:
            length = min(struct.unpack(">I", packet[12:16])[0] >> 16, 2048)
            data = bytes((memory * 2)[offset:offset + length])
            body = response(7, length << 16)
            padded = data + bytes(-len(data) % 4)
            body += struct.pack(">I", crc32(body)) + padded + struct.pack(">I", crc32(padded))
            sock.sendto(body + bytes(8), peer)
        elif tcode == 0:
            memory[offset:offset + 4] = packet[12:16]
        elif tcode == 1 and len(packet) >= 20:
            length = struct.unpack(">I", packet[12:16])[0] >> 16
            data = packet[20:20 + length]
            end_at = min(offset + len(data), 65536)
            memory[offset:end_at] = data[:end_at - offset]
    """
)


@pytest.mark.process
def test_an_independent_node_is_fuzzed_like_any_other(tmp_path: Path) -> None:
    script = tmp_path / "node.py"
    script.write_text(INDEPENDENT_NODE)
    with process(sys.executable, str(script), LIMIT) as (_, line):
        settings = Settings(
            f"udp:{address(line)}", eth1394=True, max_cases=400, shrink_budget=5, state_every=0
        )
        report = run(settings)
    found = {(f.oracle, f.signature.split(":")[0]) for f in report.findings}
    assert ("silence", "bad-header-crc") in found  # answered anyway
    assert report.checks["liveness"] >= 400
    assert not any(f.oracle == "liveness" for f in report.findings)


def test_udp_target_spec() -> None:
    target = UdpTarget.open("127.0.0.1:9", node_id=0xFFC0, eth1394=False, timeout=0.1)
    try:
        assert target.description.startswith("udp:127.0.0.1:9")
    finally:
        target.close()


def bus_node(name: str, *extra: str) -> subprocess.Popen[bytes]:
    command = [sys.executable, "-m", "fw1394.cli.bus", "node", "run", "--name", name]
    command += ["--rank", "0", "--policy", "thesis", "--parent-pid", str(os.getpid()), "--quiet"]
    return subprocess.Popen([*command, *extra], stdin=subprocess.DEVNULL)


@pytest.mark.parametrize("defect", [None, "answers-other-node"])
@pytest.mark.process
def test_a_node_on_the_virtual_bus(defect: str | None) -> None:
    name = f"fuzz{os.getpid()}{defect or ''}"
    node = bus_node(name, *(("--defect", defect) if defect else ()))
    try:
        settings = Settings(f"bus:{name}/0", model="memory", max_cases=300, timeout=1.0)
        report = run(settings)
    finally:
        node.terminate()
        node.wait(5)
    assert report.checks["liveness"] >= 300 and report.checks["silence"] > 50
    if defect is None:
        assert report.findings == [], report.lines()
    else:
        assert any(f.signature.startswith("other-node:") for f in report.findings)


@pytest.mark.process
def test_a_node_refuses_an_unknown_defect(capfd: pytest.CaptureFixture[str]) -> None:
    node = bus_node("fuzz-unknown", "--defect", "nonsense")
    assert node.wait(30) == 2
    assert "unknown defect 'nonsense'" in capfd.readouterr().err
