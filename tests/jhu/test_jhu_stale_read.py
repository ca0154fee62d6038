"""The 12-byte quadlet read over Ethernet (jhu-eth1394.md §3.2): a QREAD whose 1394
part is its three header quadlets, no CRC, gets a reply flagged as owed but no
register read, so it carries the data of the previous read.

Datagrams are built here from the spec's tables (§1.1, §2.3) and sent from a plain
socket to a live server on loopback; replies are read by the §2.4-2.6 layout.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator

import pytest
from spec_crc import crc32_1394 as crc32_bzip2

from fw1394.boards.qla1.eth_server import Eth1394Server
from fw1394.boards.qla1.rack import Rack
from fw1394.transport.eth1394_addresses import Endpoint

Served = tuple[Eth1394Server, socket.socket]

HW_VERSION, STATUS, FW_VERSION = 4, 0, 7
QLA1 = 0x514C4131
HOST_SOURCE = 0xFFD0
QRESP_TCODE, QREAD_TCODE = 6, 4
QUADLET_RESPONSE_DATAGRAM = 20 + 8  # QRESP + the extra bytes (§2.4)


def qread(node: int, register: int, tl: int, *, with_crc: bool, generation: int = 0) -> bytes:
    """A no-forward quadlet read datagram: control word, Q0-Q2 and (or not) the CRC."""
    header = struct.pack(
        ">III",
        (0x3FF << 22) | (node << 16) | (tl << 10) | (QREAD_TCODE << 4),
        HOST_SOURCE << 16,
        register,
    )
    crc = struct.pack(">I", crc32_bzip2(header)) if with_crc else b""
    return bytes((0x01, generation)) + header + crc


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


@pytest.fixture
def served() -> Iterator[Served]:
    server = Eth1394Server(Rack([2], firmware=8), Endpoint("127.0.0.1", free_port()))
    host = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    host.bind(("127.0.0.1", 0))
    host.settimeout(2.0)
    yield server, host
    host.close()
    server.close()


def ask(served: Served, request: bytes) -> bytes:
    server, host = served
    host.sendto(request, ("127.0.0.1", server.endpoint.port))
    server.step(1.0)
    return host.recv(4096)


def quadlet_reply(reply: bytes, tl: int, board: int) -> int:
    """The data of a quadlet read reply, after the checks of §2.4-2.6."""
    assert len(reply) == QUADLET_RESPONSE_DATAGRAM
    q0, q1, _q2, data, header_crc = struct.unpack(">5I", reply[:20])
    assert (q0 >> 16, (q0 >> 10) & 0x3F, (q0 >> 4) & 0xF) == (HOST_SOURCE, tl, QRESP_TCODE)
    assert q1 >> 16 == 0xFFC0 | board  # no-forward: the reply node is the board id
    assert header_crc == 0  # the Ethernet path's zero CRC
    assert reply[20] & 0x10  # extra byte 0 bit 4 echoes no-forward
    return int(data)


def test_a_12_byte_read_returns_the_previous_reads_data(served: Served) -> None:
    fresh = quadlet_reply(ask(served, qread(2, HW_VERSION, 1, with_crc=True)), 1, 2)
    assert fresh == QLA1
    # STATUS holds the board id in bits 27..24; the stale read must not read it.
    stale = quadlet_reply(ask(served, qread(2, STATUS, 2, with_crc=False)), 2, 2)
    assert stale == QLA1
    status = quadlet_reply(ask(served, qread(2, STATUS, 3, with_crc=True)), 3, 2)
    assert (status >> 24) & 0xF == 2 and status != QLA1
    assert quadlet_reply(ask(served, qread(2, FW_VERSION, 4, with_crc=False)), 4, 2) == status


def test_a_12_byte_read_after_power_up_returns_zero(served: Served) -> None:
    assert quadlet_reply(ask(served, qread(2, HW_VERSION, 9, with_crc=False)), 9, 2) == 0


def test_14_byte_read_is_answered_normally_and_11_bytes_not_at_all(served: Served) -> None:
    # From 14 bytes on the read starts at the last word (§3.2): a fresh answer.
    short = qread(2, HW_VERSION, 5, with_crc=True)[:-2]
    assert quadlet_reply(ask(served, short), 5, 2) == QLA1
    server, host = served
    host.sendto(qread(2, HW_VERSION, 6, with_crc=False)[:-1], ("127.0.0.1", server.endpoint.port))
    server.step(0.2)
    host.settimeout(0.2)
    with pytest.raises(TimeoutError):
        host.recv(4096)  # under 12 bytes the packet never becomes fresh
