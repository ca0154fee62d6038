"""The real-time loop's broadcast write, received on a socket and read by the spec's layouts.

jhu-eth1394.md §1.1 (header quadlets), §1.5 (CRC-32/BZIP2), §4.4 (DAC command
bits) and §4.6 (the write block per firmware) are written out here; the loop's
datagram is taken off a real loopback socket, not from the client's records.
An idle cycle (no commands) must send exactly what commanding every board
with the default command sends.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from spec_crc import crc32_1394 as crc32_bzip2

from fw1394.jhu.client import EthUdpClient
from fw1394.jhu.rt_loop import Command, RealTimeLoop
from fw1394.jhu.scan import Protocol, ScannedBoard, ScanResult
from fw1394.transport.eth1394_addresses import Endpoint

QLA1 = 0x514C4131
DAC_VALID = 1 << 31  # §4.4: bit 31 valid
MIDRANGE = 0x8000
IDLE_DAC = DAC_VALID | MIDRANGE
BROADCAST_DESTINATION = 0xFFFF  # bus 0x3FF, node 63
HOST_SOURCE = 0xFFD0
TCODE_BLOCK_WRITE = 1


def spec_block(board_id: int, firmware: int, dacs: list[int], control: int) -> list[int]:
    """§4.6: one board's share of the write."""
    if firmware >= 8:
        return [board_id << 8 | len(dacs) + 2, *dacs, control]
    tagged = [value & ~(0xF << 24) | board_id << 24 for value in dacs]  # board id in 27:24
    return [*tagged, control] if firmware == 7 else tagged


@pytest.fixture(scope="module")
def listener() -> Iterator[socket.socket]:
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.bind(("127.0.0.1", 0))
    sock.settimeout(2.0)
    yield sock
    sock.close()


def loop_for(port: int, ids: list[int], firmware: int) -> RealTimeLoop:
    boards = [ScannedBoard(n, board_id, QLA1, firmware, 3, 0) for n, board_id in enumerate(ids)]
    scan = ScanResult(boards=boards, bridge=True, protocol=Protocol.SEQ_R_BC_W)
    # Bridge mode: the broadcast write goes to the hub's address, here the listener.
    client = EthUdpClient(Endpoint("127.0.0.1", port), force_bridge=True)
    return RealTimeLoop(client, scan)


def received_write(listener: socket.socket) -> tuple[int, list[int]]:
    """(tl, data quadlets) of a block write datagram, checked field by field (§1.1)."""
    payload = listener.recv(65535)
    assert payload[0] & 1 == 0  # bridge mode: no-forward clear
    packet = payload[2:]
    q0, q1, q2, q3, header_crc = struct.unpack_from(">5I", packet)
    assert q0 >> 16 == BROADCAST_DESTINATION and q0 >> 4 & 0xF == TCODE_BLOCK_WRITE
    assert q0 & 0x30F == 0  # rt 0, pri 0
    assert q1 == HOST_SOURCE << 16 and q2 == 0  # offset 0
    length = q3 >> 16
    assert header_crc == crc32_bzip2(packet[:16])
    data = packet[20 : 20 + length]
    assert len(packet) == 20 + length + 4
    assert struct.unpack_from(">I", packet, 20 + length)[0] == crc32_bzip2(data)
    return q0 >> 10 & 0x3F, list(struct.unpack(f">{length // 4}I", data))


commands = st.builds(
    Command,
    dac=st.lists(st.integers(0, 0xFFFFFFFF), min_size=4, max_size=4).map(tuple),
    control=st.sampled_from([0, 0x000C_0000, 0x000A_0000, 0x0000_0F0F]),
)


@settings(max_examples=40, deadline=None)
@given(
    ids=st.lists(st.integers(0, 15), min_size=1, max_size=8, unique=True),
    firmware=st.sampled_from([7, 8, 9]),
    commanded=st.dictionaries(st.integers(0, 15), commands, max_size=4),
)
def test_the_broadcast_write_carries_every_boards_block(
    listener: socket.socket, ids: list[int], firmware: int, commanded: dict[int, Command]
) -> None:
    port = listener.getsockname()[1]
    loop = loop_for(port, ids, firmware)
    with loop.client:
        for given_commands in (None, commanded):
            assert loop.write_all(given_commands)
            _, words = received_write(listener)
            expected: list[int] = []
            for board_id in sorted(ids):
                command = (given_commands or {}).get(board_id, Command())
                expected += spec_block(board_id, firmware, list(command.dac), command.control)
            assert words == expected


@pytest.mark.parametrize("firmware", [7, 8, 9])
def test_an_idle_cycle_sends_what_default_commands_send(
    listener: socket.socket, firmware: int
) -> None:
    ids = [0, 1, 2, 3, 4, 5, 6, 7]
    loop = loop_for(listener.getsockname()[1], ids, firmware)
    with loop.client:
        loop.write_all()
        first_tl, idle = received_write(listener)
        loop.write_all(dict.fromkeys(ids, Command()))
        second_tl, commanded = received_write(listener)
    assert idle == commanded
    first_dac = 1 if firmware >= 8 else 0  # after the header from Rev 8 on
    assert idle[first_dac] == IDLE_DAC  # board 0: its id tag (before Rev 8) is 0
    assert second_tl == first_tl + 1  # the label moves on before every request (§1.3)
