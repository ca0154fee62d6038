"""The host library's start-up scan (§4.9) and real-time loop, replayed against fw1394 boards.

Bridge mode (firmware 8) runs on this machine's loopback: the host's
broadcasts go to 127.255.255.255, everything else to 127.0.0.1. Ethernet-only
mode (firmware 9) multicasts to 224.0.0.100, so it runs only inside a network
namespace this test creates, with the multicast route on ``lo``.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
from collections.abc import Iterator

import pytest
from udp_ports_support import quiet_udp_port

from fw1394.boards.qla1.eth_server import Eth1394Server, MulticastRefusedError
from fw1394.boards.qla1.rack import Rack
from fw1394.boards.qla1.regs import DAC_VALID
from fw1394.jhu.client import EthUdpClient
from fw1394.jhu.rt_loop import Command, RealTimeLoop
from fw1394.jhu.scan import Protocol, start
from fw1394.transport.eth1394_addresses import Endpoint

PORT = quiet_udp_port(span=10)
POWER_ON = 0x000C0000  # STATUS command: power enable (mask bit 19, value bit 18)


def serve(rack: Rack, port: int) -> tuple[Eth1394Server, threading.Thread]:
    server = Eth1394Server(rack, Endpoint("127.0.0.1", port))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    return server, thread


@pytest.mark.parametrize("boards", [1, 4])
def test_bridge_mode_scan_and_realtime_loop(boards: int) -> None:
    port = PORT + boards
    server, thread = serve(Rack(list(range(boards)), firmware=8), port)
    try:
        with EthUdpClient(Endpoint("127.0.0.1", port), receive_timeout=RECEIVE_TIMEOUT) as client:
            scan = start(client)
            assert "Initialization done" in client.state.log
            assert scan.bridge and [b.board_id for b in scan.boards] == list(range(boards))
            assert scan.gap_count_written == (5, 7, 8, 10)[boards - 1]
            # The exact first datagrams of a start-up (§1.6): IP write, HW version.
            (first, ip_write), (_, hw_read) = list(client.sent)[:2]
            assert first == ("127.255.255.255", port)
            assert ip_write.hex() == "0100ffff0400ffd000000000000b0100007f11c036d8"
            assert hw_read.hex() == "0100ffff0840ffd0000000000004" + "58ffb182"
            for protocol in Protocol:
                loop = RealTimeLoop(client, scan, protocol)
                commands = {b: Command(control=POWER_ON) for b in range(boards)}
                for _ in range(20):
                    blocks = loop.cycle(commands)
                    assert all(block is not None for block in blocks.values()), protocol
                for board_id, block in loop.cycle(commands).items():
                    assert block is not None and len(block) == 32
                    assert (block[1] >> 24) & 0xF == board_id
                    assert block[1] & 0x00040000  # power on, by the control quadlet
    finally:
        server.stop()
        thread.join(5)
        server.close()
    assert server.stats.refused == 0


def test_dac_commands_come_back_in_the_block() -> None:
    port = PORT + 7
    rack = Rack([2], firmware=8)
    server, thread = serve(rack, port)
    try:
        with EthUdpClient(Endpoint("127.0.0.1", port), receive_timeout=RECEIVE_TIMEOUT) as client:
            scan = start(client)
            loop = RealTimeLoop(client, scan, Protocol.SEQ_RW)
            dac = tuple(DAC_VALID | 0x9000 + n for n in range(4))
            loop.cycle({2: Command(dac=dac, control=POWER_ON)})
            loop.cycle({2: Command(dac=dac, control=0x00000F0F)})  # amplifiers on
            block = loop.cycle({2: Command(dac=dac)})[2]
            assert block is not None
            assert [word & 0xFFFF for word in block[4:8]] == [0x9000 + n for n in range(4)]
    finally:
        server.stop()
        thread.join(5)
        server.close()


def test_firmware_9_is_refused_outside_a_loopback_multicast_route() -> None:
    from fw1394.transport.eth1394_addresses import multicast_route_check

    if multicast_route_check() is None:
        pytest.skip("this machine's multicast route is on lo (or missing): nothing to refuse")
    with pytest.raises(MulticastRefusedError):
        Eth1394Server(Rack([0], firmware=9), Endpoint("127.0.0.1", PORT + 9))


# -- Ethernet-only mode, in a network namespace of its own -----------------------------------

needs_netns = pytest.mark.skipif(
    os.geteuid() != 0 or shutil.which("ip") is None,
    reason="needs root and iproute2 (ip) to create a network namespace",
)


def ip(*args: str) -> None:
    subprocess.run(["ip", *args], check=True, capture_output=True, timeout=10)


@pytest.fixture
def namespace() -> Iterator[str]:
    name = f"fwjhu{os.getpid() % 100000}"
    ip("netns", "add", name)
    try:
        ip("-n", name, "link", "set", "lo", "up")
        ip("-n", name, "route", "add", "224.0.0.0/4", "dev", "lo")
        yield name
    finally:
        subprocess.run(["ip", "netns", "del", name], capture_output=True, timeout=10)


#: The host library waits 20 ms for each answer; the tests share a loaded 2-core
#: machine with other suites, so they give answers ten times as long.
RECEIVE_TIMEOUT = 0.2


def fw1394(namespace: str, *args: str) -> list[str]:
    return ["ip", "netns", "exec", namespace, sys.executable, "-m", "fw1394.cli.main", *args]


@needs_netns
@pytest.mark.parametrize("boards", [1, 4])
@pytest.mark.process
@pytest.mark.netns
@pytest.mark.slow
def test_ethernet_only_mode_in_a_namespace(namespace: str, boards: int) -> None:
    server = subprocess.Popen(
        fw1394(
            namespace,
            "jhu",
            "serve",
            "--boards",
            str(boards),
            "--firmware",
            "9",
            "--duration",
            "30",
        ),
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert server.stderr is not None
        banner = server.stderr.readline()  # printed once every socket is bound
        assert "224.0.0.100:1394" in banner, banner
        for protocol in ("sequential", "broadcast-write", "broadcast-read-write"):
            done = subprocess.run(
                fw1394(
                    namespace,
                    "jhu",
                    "rt",
                    "-p",
                    "udp:127.0.0.1",
                    "--cycles",
                    "50",
                    "--protocol",
                    protocol,
                    "--json",
                    "--receive-timeout",
                    str(RECEIVE_TIMEOUT),
                ),
                capture_output=True,
                text=True,
                timeout=30,
            )
            assert done.returncode == 0, done.stderr
            report = json.loads(done.stdout)
            assert report["complete"] == 50
            # The scan the loop began with, as `jhu scan --json` prints it.
            found = report["scan"]
            assert found["mode"] == "ethernet-only"
            assert [b["board_id"] for b in found["boards"]] == list(range(boards))
            assert [b["node"] for b in found["boards"]] == list(range(boards))  # node = board
    finally:
        server.terminate()
        server.wait(10)
