"""The configuration PROM (M25P16) and the QLA PROM (25AA128) behind the board registers.

The register protocol is the JHU host library's (jhu-eth1394.md §4.1, §4.2, §4.10;
FpgaIO's PROM helpers): register 8 takes ``instruction << 24 | address``, a read of
register 8 is the interface status (bits 3..0 busy), register 9 the result, 0x2000
the page buffer; the QLA PROM sits at 0x3000 (command), 0x3002 (result), 0x3100
(buffer). The instruction codes and the JEDEC ID are the M25P16 data sheet's.

The last test programs and verifies an image as ``pgm1394`` does, over real UDP
against ``jhu serve``'s server, with datagrams built here from §1.2 and §2.3.
"""

from __future__ import annotations

import random
import socket
import threading
from collections.abc import Iterator

import pytest
from udp_ports_support import quiet_udp_port

from fw1394.boards.qla1.board import Qla1Board

PROM_COMMAND, PROM_RESULT, PAGE_BUFFER = 8, 9, 0x2000
READ_ID, READ_STATUS, WRITE_ENABLE, WRITE_DISABLE = 0x9F, 0x05, 0x06, 0x04
READ_DATA, SECTOR_ERASE, BULK_ERASE, PAGE_PROGRAM = 0x03, 0xD8, 0xC7, 0x02
WIP, WEL = 1, 2
MS = 49_152  # board ticks per millisecond


def words_of(data: bytes) -> list[int]:
    return [int.from_bytes(data[n : n + 4], "big") for n in range(0, len(data), 4)]


def command(board: Qla1Board, instruction: int, address: int = 0) -> int:
    board.write_quadlet(PROM_COMMAND, instruction << 24 | address)
    return board.read_quadlet(PROM_RESULT)


def read_prom(board: Qla1Board, address: int, count: int) -> bytes:
    assert command(board, READ_DATA, address) == 64  # quadlets now in the page buffer
    return board.read_block(PAGE_BUFFER, count)


def program(board: Qla1Board, address: int, data: bytes) -> int:
    board.write_block(PAGE_BUFFER, (PAGE_PROGRAM << 24 | address).to_bytes(4, "big") + data)
    return board.read_quadlet(PROM_RESULT)


def wait_ready(board: Qla1Board) -> None:
    for _ in range(100):
        if not command(board, READ_STATUS) & WIP:
            return
        board.set_time(board.now + MS // 10)
    raise AssertionError("the PROM stays busy")


def test_identification_and_idle_interface() -> None:
    board = Qla1Board(board_id=1)
    assert command(board, READ_ID) == 0x202015  # ST M25P16: 0x20, 0x20, 16 Mbit
    assert board.read_quadlet(PROM_COMMAND) & 0xF == 0  # interface not busy


def test_serial_number_where_the_host_reads_it() -> None:
    board = Qla1Board(board_id=3)
    data = read_prom(board, 0x1FFF00, 16)
    assert data.startswith(b"FPGA ")
    assert data[5:12] == b"1394-03" and data[12] == 0xFF


def test_write_enable_latch_and_disable() -> None:
    board = Qla1Board(board_id=0)
    assert command(board, READ_STATUS) == 0
    command(board, WRITE_ENABLE)
    assert command(board, READ_STATUS) == WEL
    command(board, WRITE_DISABLE)
    assert command(board, READ_STATUS) == 0


def test_erased_reads_ff_and_program_needs_write_enable() -> None:
    board = Qla1Board(board_id=0)
    assert read_prom(board, 0x40000, 8) == b"\xff" * 8
    assert program(board, 0x40000, b"\x12\x34\x56\x78") == 2  # command + 1 data quadlet
    assert read_prom(board, 0x40000, 4) == b"\xff" * 4, "not enabled: nothing written"
    command(board, WRITE_ENABLE)
    program(board, 0x40000, b"\x12\x34\x56\x78")
    assert command(board, READ_STATUS) & WIP, "busy while programming"
    wait_ready(board)
    assert command(board, READ_STATUS) & WEL == 0, "cleared at the end of the write"
    assert read_prom(board, 0x40000, 8) == b"\x12\x34\x56\x78" + b"\xff" * 4


def test_program_only_clears_bits_and_erase_sets_them() -> None:
    board = Qla1Board(board_id=0)
    for data in (b"\x0f\x0f\x0f\x0f", b"\xf0\xff\x00\xff"):
        command(board, WRITE_ENABLE)
        program(board, 0x10000, data)
        wait_ready(board)
    assert read_prom(board, 0x10000, 4) == b"\x00\x0f\x00\x0f"
    command(board, WRITE_ENABLE)
    command(board, SECTOR_ERASE, 0x1ABCD)  # any address inside sector 1
    assert command(board, READ_STATUS) & WIP
    wait_ready(board)
    assert read_prom(board, 0x10000, 4) == b"\xff" * 4


def test_erase_touches_only_its_sector_bulk_erase_everything() -> None:
    board = Qla1Board(board_id=0)
    for address in (0x0FFFC, 0x10000):
        command(board, WRITE_ENABLE)
        program(board, address, b"\x00\x00\x00\x00")
        wait_ready(board)
    command(board, WRITE_ENABLE)
    command(board, SECTOR_ERASE, 0x10000)
    wait_ready(board)
    assert read_prom(board, 0x0FFFC, 8) == b"\x00" * 4 + b"\xff" * 4
    command(board, WRITE_ENABLE)
    command(board, BULK_ERASE)
    wait_ready(board)
    assert read_prom(board, 0x0FFFC, 4) == b"\xff" * 4
    assert read_prom(board, 0x1FFF00, 5) == b"\xff" * 5


def test_page_program_wraps_inside_its_page() -> None:
    board = Qla1Board(board_id=0)
    command(board, WRITE_ENABLE)
    program(board, 0x200FC, b"\x01\x02\x03\x04\x05\x06\x07\x08")
    wait_ready(board)
    assert read_prom(board, 0x200FC, 4) == b"\x01\x02\x03\x04"
    assert read_prom(board, 0x20000, 4) == b"\x05\x06\x07\x08"  # back to the page start
    assert read_prom(board, 0x20100, 4) == b"\xff" * 4


def test_busy_chip_ignores_a_second_write() -> None:
    board = Qla1Board(board_id=0)
    command(board, WRITE_ENABLE)
    command(board, SECTOR_ERASE, 0)
    command(board, WRITE_ENABLE)  # ignored while busy
    program(board, 0, b"\x00\x00\x00\x00")
    wait_ready(board)
    assert read_prom(board, 0, 4) == b"\xff" * 4


def test_contents_survive_a_reboot() -> None:
    board = Qla1Board(board_id=0, firmware=8)
    command(board, WRITE_ENABLE)
    program(board, 0x30000, b"\xab\xcd\xef\x01")
    wait_ready(board)
    board.write_quadlet(0, 0x00300000)  # reboot
    assert read_prom(board, 0x30000, 4) == b"\xab\xcd\xef\x01"


def test_qla_prom_serial_by_byte_and_by_block() -> None:
    board = Qla1Board(board_id=5)
    text = bytearray()
    for address in range(12):
        board.write_quadlet(0x3000, 0x03 << 24 | address << 8)
        text.append(board.read_quadlet(0x3002) & 0xFF)
    assert text == b"QLA 1394-05\xff"
    board.write_quadlet(0x3000, 0xFE << 24 | 0 << 8 | 2)  # 3 quadlets from address 0
    assert board.read_block(0x3100, 12) == b"QLA 1394-05\xff"


def test_qla_prom_block_write_needs_write_enable() -> None:
    board = Qla1Board(board_id=0)
    board.write_block(0x3100, b"QLA 9999-99\x00")
    board.write_quadlet(0x3000, 0xFF << 24 | 0x40 << 8 | 2)
    board.write_quadlet(0x3000, 0xFE << 24 | 0x40 << 8 | 2)
    assert board.read_block(0x3100, 12) == b"\xff" * 12
    board.write_block(0x3100, b"QLA 9999-99\x00")
    board.write_quadlet(0x3000, 0x06 << 24)
    board.write_quadlet(0x3000, 0xFF << 24 | 0x40 << 8 | 2)
    board.write_quadlet(0x3000, 0xFE << 24 | 0x40 << 8 | 2)
    assert board.read_block(0x3100, 12) == b"QLA 9999-99\x00"


# -- pgm1394 over UDP, with datagrams built here ---------------------------------------------


class HandHost:
    """The few Eth1394 requests pgm1394 needs, built from jhu-eth1394.md §1.2 and §2.3.

    Datagram: control word (no-forward, generation 0), then big-endian quadlets:
    Q0 = 0xFFC0 | node, label, tcode; Q1 = source 0xFFD0; Q2 = offset; CRCs left 0
    (the boards' Ethernet path never checks them, §1.5).
    """

    def __init__(self, port: int) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.settimeout(5)
        self.address = ("127.0.0.1", port)
        self.label = 0

    def _send(self, tcode: int, offset: int, *rest: int, data: bytes = b"") -> None:
        self.label = (self.label + 1) % 64
        header = [0xFFC0 << 16 | self.label << 10 | tcode << 4, 0xFFD0 << 16, offset, *rest]
        packet = b"".join(q.to_bytes(4, "big") for q in header) + b"\0\0\0\0"
        if data:
            packet += data + b"\0\0\0\0"
        self.sock.sendto(b"\x01\x00" + packet, self.address)

    def write_quadlet(self, offset: int, value: int) -> None:
        self._send(0, offset, value)

    def write_block(self, offset: int, data: bytes) -> None:
        self._send(1, offset, len(data) << 16, data=data)

    def read_quadlet(self, offset: int) -> int:
        self._send(4, offset)
        reply = self.sock.recv(2048)
        assert len(reply) == 28 and reply[3] >> 4 == 6  # QRESP + 8 extra bytes
        return int.from_bytes(reply[12:16], "big")

    def read_block(self, offset: int, count: int) -> bytes:
        self._send(5, offset, count << 16)
        reply = self.sock.recv(4096)
        assert len(reply) == 32 + count and reply[3] >> 4 == 7  # BRESP + CRC + extra
        return reply[20 : 20 + count]

    def status(self) -> int:
        self.write_quadlet(PROM_COMMAND, READ_STATUS << 24)
        return self.read_quadlet(PROM_RESULT)


@pytest.fixture
def server_port() -> Iterator[int]:
    from fw1394.boards.qla1.eth_server import Eth1394Server
    from fw1394.boards.qla1.rack import Rack
    from fw1394.transport.eth1394_addresses import Endpoint

    port = quiet_udp_port()
    server = Eth1394Server(Rack([0], firmware=8), Endpoint("127.0.0.1", port))
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield port
    finally:
        server.stop()
        thread.join(5)
        server.close()


@pytest.mark.process
def test_pgm1394_style_program_and_verify_over_udp(server_port: int) -> None:
    host = HandHost(server_port)
    host.write_quadlet(PROM_COMMAND, READ_ID << 24)
    assert host.read_quadlet(PROM_RESULT) == 0x202015
    image = bytes(random.Random(1394).randrange(256) for _ in range(1000))
    start = 0x050000
    # Erase the sectors the image covers, waiting for each.
    for sector in range(start, start + len(image), 0x10000):
        host.write_quadlet(PROM_COMMAND, WRITE_ENABLE << 24)
        host.write_quadlet(PROM_COMMAND, SECTOR_ERASE << 24 | sector)
        while host.status() & WIP:
            pass
    # Program 256-byte pages: enable, block write {command, data} to the page buffer,
    # interface done, result = quadlets written (command included), chip done.
    for page in range(0, len(image), 256):
        chunk = image[page : page + 256]
        chunk += b"\xff" * (-len(chunk) % 4)
        host.write_quadlet(PROM_COMMAND, WRITE_ENABLE << 24)
        host.write_block(
            PAGE_BUFFER, (PAGE_PROGRAM << 24 | start + page).to_bytes(4, "big") + chunk
        )
        while host.read_quadlet(PROM_COMMAND) & 0xF:
            pass
        assert host.read_quadlet(PROM_RESULT) == 1 + len(chunk) // 4
        while host.status() & WIP:
            pass
    # Verify 64 bytes at a time, as the library reads.
    read = bytearray()
    for piece in range(0, len(image), 64):
        host.write_quadlet(PROM_COMMAND, READ_DATA << 24 | start + piece)
        while host.read_quadlet(PROM_COMMAND) & 0xF:
            pass
        assert host.read_quadlet(PROM_RESULT) == 64
        count = min(64, len(image) - piece)
        read += host.read_block(PAGE_BUFFER, count + (-count % 4))[:count]
    assert bytes(read) == image
    host.write_quadlet(PROM_COMMAND, READ_DATA << 24 | start + len(image) + 24)
    assert host.read_block(PAGE_BUFFER, 8) == b"\xff" * 8, "past the image: still erased"
