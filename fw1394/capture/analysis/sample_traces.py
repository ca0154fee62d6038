"""Small sample traces, built from documented packets: for tests, docs and demos.

The Eth1394 sample replays datagrams the real JHU host and FPGA exchanged
(``jhu-eth1394.md`` §1.6): each UDP payload is wrapped in IPv4 and Ethernet
headers as ``tcpdump -i lo`` would have captured it.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable

from fw1394.capture.formats.pcap_writer import LINKTYPE_ETHERNET, open_writer
from fw1394.packets.eth1394 import UDP_PORT

HOST = "127.0.0.1"
BOARD = "127.0.0.2"
#: (sender, UDP payload hex) pairs: a quadlet read with its answer, a block read with
#: its answer, a block write (never answered), a read whose answer never came.
ETH1394_EXCHANGE: tuple[tuple[str, str], ...] = (
    (HOST, "0105 ffc01c40 ffd00000 00000004 a9927b79"),
    (BOARD, "ffd01c60 ffc00000 00000000 514c4131 00000000 10050000 006400c8"),
    (HOST, "0105 ffc02840 ffd00000 00000000 c0518b0f"),
    (BOARD, "ffd02860 ffc00000 00000000 4b000000 00000000 10050000 005000a0"),
    (HOST, "0105 ffc06c10 ffd00000 00002000 000c0000 cca946ca 00000011 00000022 00000033 54289f99"),
    (HOST, "0105 ffc09c50 ffd00000 00000000 00800000 fc9a49db"),
)


def _checksum(header: bytes) -> int:
    total = int(sum(struct.unpack(f"!{len(header) // 2}H", header)))
    while total >> 16:
        total = (total & 0xFFFF) + (total >> 16)
    return ~total & 0xFFFF


def _address(text: str) -> bytes:
    return bytes(int(part) for part in text.split("."))


def ethernet_frame(
    source: str, destination: str, payload: bytes, port: int = UDP_PORT, ident: int = 1
) -> bytes:
    """An Ethernet/IPv4/UDP frame carrying ``payload`` from port ``port`` to ``port``."""
    udp = struct.pack("!HHHH", port, port, 8 + len(payload), 0) + payload
    header = struct.pack(
        "!BBHHHBBH4s4s",
        0x45,
        0,
        20 + len(udp),
        ident,
        0x4000,
        64,
        17,
        0,
        _address(source),
        _address(destination),
    )
    header = header[:10] + struct.pack("!H", _checksum(header)) + header[12:]
    return bytes(6) + bytes(6) + b"\x08\x00" + header + udp


def eth1394_frames(
    exchange: Iterable[tuple[str, str]] = ETH1394_EXCHANGE, port: int = UDP_PORT
) -> list[bytes]:
    frames = []
    for ident, (sender, text) in enumerate(exchange, start=1):
        payload = bytes.fromhex(text.replace(" ", ""))
        receiver = BOARD if sender == HOST else HOST
        frames.append(ethernet_frame(sender, receiver, payload, port, ident))
    return frames


def write_eth1394_sample(path: str, container: str = "pcap", port: int = UDP_PORT) -> int:
    """Write the Eth1394 sample exchange, 100 µs apart; returns the frame count."""
    frames = eth1394_frames(port=port)
    with open_writer(path, LINKTYPE_ETHERNET, container) as writer:
        for index, frame in enumerate(frames):
            writer.write(1_700_000_000_000_000_000 + 100_000 * index, frame)
    return len(frames)
