"""Firmware >= 9 with the documented namespace setup: the host's multicast leaves from 0.0.0.0.

In a network namespace set up as fw1394's documentation says (``ip link set lo
up; ip route add 224.0.0.0/4 dev lo``), a socket that multicasts without
IP_MULTICAST_IF, as the real host library does (jhu-eth1394.md §2.1: an unbound
socket, SO_BROADCAST, no interface chosen), sends its ETH_STATUS read from the
unspecified address 0.0.0.0, since the route has no source address. The firmware
answers the request's source address and port; the server must too, so the
host gets its answer (the library otherwise prints "failed to read Ethernet
status from hub/bridge board" and finds no board).

The namespace is created by the test (``unshare -n``); nothing leaves it.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import textwrap

import pytest

from fw1394.boards.qla1.eth_server import Eth1394Server, RefusalLog, reply_address
from fw1394.boards.qla1.ethernet import Reply
from fw1394.boards.qla1.rack import Rack
from fw1394.packets.eth1394 import ExtraBytes
from fw1394.transport.eth1394_addresses import Endpoint

needs_namespace = pytest.mark.skipif(
    os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("ip"),
    reason="needs root, unshare and iproute2 to create a network namespace",
)

# The host's ETH_STATUS read of InitNodes step 7 (tl 6, no-forward, broadcast node).
CHILD = textwrap.dedent(
    """
    import json, socket, subprocess, threading
    from fw1394.boards.qla1.eth_server import Eth1394Server
    from fw1394.boards.qla1.rack import Rack
    from fw1394.packets import QuadletReadRequest
    from fw1394.packets.eth1394 import ControlWord, Eth1394Request, build_request
    from fw1394.packets.fast import decode_packet, encode_packet
    from fw1394.transport.eth1394_addresses import Endpoint

    subprocess.run(["ip", "link", "set", "lo", "up"], check=True)
    subprocess.run(["ip", "route", "add", "224.0.0.0/4", "dev", "lo"], check=True)
    rack = Rack([0], firmware=9)
    refusals = []
    server = Eth1394Server(rack, Endpoint("127.0.0.1", 1394), say=refusals.append)
    threading.Thread(target=server.serve_forever, daemon=True).start()

    host = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    host.setsockopt(socket.SOL_SOCKET, socket.SO_BROADCAST, 1)  # and nothing else
    request = QuadletReadRequest(destination_id=0xFFFF, tlabel=6, source_id=0xFFD0, offset=12)
    control = ControlWord(no_forward=True)
    host.sendto(build_request(Eth1394Request(control, encode_packet(request))),
                ("224.0.0.100", 1394))
    host.settimeout(2.0)
    try:
        answer = host.recv(28)
    except TimeoutError:
        answer = b""
    server.stop()
    data = decode_packet(answer[:20]).quadlet_data if len(answer) == 28 else None
    print(json.dumps({
        "sender": rack.members[0].port.last_host[0],
        "answer": data,
        "refused": server.stats.refused,
        "log": refusals,
    }))
    """
)


@needs_namespace
@pytest.mark.process
def test_multicast_read_from_unspecified_source_is_answered() -> None:
    result = subprocess.run(
        ["unshare", "-n", sys.executable, "-c", CHILD],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0, result.stderr
    seen = json.loads(result.stdout.strip().splitlines()[-1])
    # The case the documented setup produces: the request comes from 0.0.0.0.
    assert seen["sender"] == "0.0.0.0"
    assert seen["refused"] == 0, seen["log"]
    assert seen["answer"] == 0x40B00000  # ETH_STATUS of an FPGA V3


def test_reply_to_unspecified_source_goes_to_this_host() -> None:
    assert reply_address(("0.0.0.0", 40000), "127.0.0.2") == ("127.0.0.2", 40000)
    assert reply_address(("127.0.0.1", 40000), "127.0.0.2") == ("127.0.0.1", 40000)


def test_refused_replies_are_logged_once_per_cause() -> None:
    said: list[str] = []
    server = Eth1394Server(Rack([0], firmware=8), Endpoint("127.0.0.1", 0), say=said.append)
    with server:
        extra = ExtraBytes()
        for port in (40001, 40002):
            server.send_reply(0, Reply(("192.0.2.1", port), b"", extra, 0.0), 0.0)
        for _ in range(2):
            server.send_reply(0, Reply(("127.0.0.1", 0), b"", extra, 0.0), 0.0)
    assert server.stats.refused == 4
    assert len(said) == 2
    assert "192.0.2.1:40001" in said[0] and "not a loopback address" in said[0]
    assert "127.0.0.1:0" in said[1] and "send failed" in said[1]


def test_refusal_log_defaults_to_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    log = RefusalLog()
    log.refused(("192.0.2.1", 1), "why")
    log.refused(("192.0.2.9", 2), "why")
    assert capsys.readouterr().err.count("cannot reply to 192.0.2.1:1: why") == 1
