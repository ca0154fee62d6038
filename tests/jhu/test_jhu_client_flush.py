"""The host's flush before a read (jhu-eth1394.md, summary item 9): every waiting datagram goes."""

from __future__ import annotations

import select
import socket

from fw1394.jhu.client import EthUdpClient
from fw1394.transport.eth1394_addresses import Endpoint


def test_flush_drops_every_waiting_datagram_and_counts_them() -> None:
    with EthUdpClient(Endpoint("127.0.0.1", 9)) as client:
        client.sock.bind(("127.0.0.1", 0))
        address = client.sock.getsockname()
        assert client.flush() == 0
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as board:
            for n in range(3):
                board.sendto(bytes([n]) * 12, address)
            assert select.select([client.sock], [], [], 2.0)[0]
            assert client.flush() == 3
            assert client.flush() == 0
            board.sendto(b"late", address)
            assert select.select([client.sock], [], [], 2.0)[0]
            assert client.flush() == 1
