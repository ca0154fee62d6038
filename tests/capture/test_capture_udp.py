"""JHU Eth1394 traffic: reading tcpdump-style captures, and capturing it live on loopback."""

from __future__ import annotations

import os
import signal
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from polling import wait_until
from udp_ports_support import quiet_udp_port

from fw1394.capture.analysis.columns import decode
from fw1394.capture.analysis.sample_traces import (
    ETH1394_EXCHANGE,
    eth1394_frames,
    write_eth1394_sample,
)
from fw1394.capture.analysis.transaction_model import Kind
from fw1394.capture.analysis.transactions import Pairer
from fw1394.capture.formats import containers, sources
from fw1394.capture.formats import eth1394_udp as udp
from fw1394.capture.formats.pcap_writer import open_writer


def payload(index: int) -> bytes:
    return bytes.fromhex(ETH1394_EXCHANGE[index][1].replace(" ", ""))


def test_payloads_are_told_apart() -> None:
    assert [udp.classify(payload(i)) for i in range(len(ETH1394_EXCHANGE))] == [
        "request",
        "response",
        "request",
        "response",
        "request",
        "request",
    ]
    assert udp.classify(bytes(8)) == "extra_only"
    assert udp.classify(b"\x00\x01\x02") is None


def test_ethernet_frames_yield_the_datagram() -> None:
    frame = eth1394_frames()[0]
    found = udp.udp_payload(1, frame)
    assert isinstance(found, udp.Datagram) and found.payload == payload(0)
    assert udp.udp_payload(1, frame, ports=(4000,)) is None
    raw_ip = frame[14:]
    assert isinstance(udp.udp_payload(101, raw_ip), udp.Datagram)


@pytest.mark.parametrize("container", ["pcap", "pcapng"])
def test_sample_capture_pairs_and_flags(tmp_path: Path, container: str) -> None:
    path = tmp_path / f"eth.{container}"
    write_eth1394_sample(str(path), container)
    assert sources.detect(str(path)) == "udp"
    pairer = Pairer()
    ended = []
    for job in sources.jobs(str(path), "udp"):
        batch = job()
        assert not batch.issues
        ended += pairer.feed(batch, decode(batch))
        records = [batch.record(i) for i in range(len(batch))]
    ended += pairer.finish()
    kinds = sorted(int(k) for tx in ended for k in tx["kind"])
    assert kinds == sorted([Kind.answered, Kind.answered, Kind.posted, Kind.unanswered])
    # The FPGA's zero CRCs are placeholders, not errors; the host's CRCs are checked.
    assert [r.crc_placeholder for r in records] == [False, True, False, True, False, False]
    assert records[1].generation == 5


def test_generation_change_becomes_a_bus_reset(tmp_path: Path) -> None:
    late = ETH1394_EXCHANGE[3][1].replace("10050000", "10060000")
    exchange = (*ETH1394_EXCHANGE[:3], (ETH1394_EXCHANGE[3][0], late))
    path = tmp_path / "reset.pcap"
    with open_writer(str(path), 1, "pcap") as writer:
        for index, frame in enumerate(eth1394_frames(exchange)):
            writer.write(index * 1000, frame)
    (batch,) = [job() for job in sources.jobs(str(path), "udp")]
    kinds = [batch.record(i).record_type.name for i in range(len(batch))]
    assert kinds == ["async_packet", "async_packet", "async_packet", "bus_reset", "async_packet"]


def _can_sniff() -> bool:
    try:
        socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(3)).close()
    except (OSError, AttributeError):
        return False
    return True


def packet_socket_on(pid: int, interface: str) -> bool:
    """Whether process ``pid`` holds a packet socket bound to ``interface``."""
    try:
        links = {os.readlink(fd) for fd in Path(f"/proc/{pid}/fd").iterdir()}
    except OSError:
        return False
    index = socket.if_nametoindex(interface)
    with open("/proc/net/packet") as table:
        rows = [line.split() for line in table.readlines()[1:]]
    # Columns: sk RefCnt Type Proto Iface R Rmem User Inode
    return any(int(row[4]) == index and f"socket:[{row[8]}]" in links for row in rows)


@pytest.mark.skipif(not _can_sniff(), reason="live UDP capture needs CAP_NET_RAW (root)")
@pytest.mark.process
def test_live_udp_capture_closes_cleanly_on_ctrl_c(tmp_path: Path) -> None:
    port = quiet_udp_port()
    path = tmp_path / "live.pcapng"
    process = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fw1394.cli.main",
            "capture",
            "--udp",
            "--port",
            str(port),
            "-w",
            str(path),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    assert process.stdout is not None and process.stderr is not None
    shown: list[str] = []  # one line per captured datagram
    reader = threading.Thread(target=lambda: shown.extend(process.stdout or ()))
    reader.start()
    try:
        wait_until(lambda: packet_socket_on(process.pid, "lo"), timeout=30)
        sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        for index in range(4):
            sender.sendto(payload(index % 2), ("127.0.0.1", port))
            time.sleep(0.02)
        sender.close()
        wait_until(lambda: len(shown) >= 4, timeout=10)
        process.send_signal(signal.SIGINT)
        process.wait(10)
        err = process.stderr.read()
    finally:
        if process.poll() is None:
            process.kill()
        reader.join(10)
    out = "".join(shown)
    assert process.returncode == 0, err
    assert "4 packets written" in err
    assert out.count("read_quadlet_request") == 2
    with open(path, "rb") as stream:
        chunks = list(containers.read_chunks(stream))
    assert sum(len(c) for c in chunks) == 4 and not any(c.issues for c in chunks)
