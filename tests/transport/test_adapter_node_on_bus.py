"""Another host addresses the adapter's node over the bus.

The requester is a second host member (``BusPort``); the program that claims
an address range of the adapter's node is written here from the byte layouts
of docs/host-adapter.md (sections 3, 4 and 8), not with fw1394's client.
"""

from __future__ import annotations

import os
import socket
import struct
import threading

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.runtime import adapter_socket

pytestmark = pytest.mark.process

CSR = 0xFFFF_F000_0000
CLAIMED = 0x1_0000_0000
REQUEST_HEAD = struct.Struct(">IBBHIQIBf")
REPLY_HEAD = struct.Struct(">IBIBbbB")
HELLO, LISTEN, RESPOND = 5, 7, 9


class DocClient:
    """Frames as the document lays them out, over the adapter's socket."""

    def __init__(self, bus: AdapterBus) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(20)
        self.sock.connect(str(adapter_socket(bus.directory)))
        self.buffer = b""

    def send(
        self,
        number: int,
        op: int,
        *,
        offset: int = 0,
        length: int = 0,
        ext: int = 0,
        data: bytes = b"",
    ) -> None:
        body = REQUEST_HEAD.pack(number, op, 0, ext, 0, offset, length, 0, 0.0)
        body += struct.pack(">I", 0) + struct.pack(">I", len(data)) + data
        self.sock.sendall(struct.pack(">I", len(body)) + body)

    def receive(self) -> tuple[int, int, bytes]:
        """(request number, status, data) of the next reply."""
        while (
            len(self.buffer) < 4 or len(self.buffer) < 4 + struct.unpack(">I", self.buffer[:4])[0]
        ):
            chunk = self.sock.recv(65536)
            assert chunk, "the adapter closed the connection"
            self.buffer += chunk
        size = struct.unpack(">I", self.buffer[:4])[0]
        body, self.buffer = self.buffer[4 : 4 + size], self.buffer[4 + size :]
        number, status = REPLY_HEAD.unpack_from(body)[:2]
        at = REPLY_HEAD.size
        at += 1 + body[at]
        at += 2 + struct.unpack_from(">H", body, at)[0]
        data_size = struct.unpack_from(">I", body, at)[0]
        return number, status, body[at + 4 : at + 4 + data_size]


def test_a_host_reads_the_adapters_rom_and_a_range_a_program_answers() -> None:
    with adapter_bus("node-on-bus", 1) as bus:
        program = DocClient(bus)
        program.send(1, HELLO, data=struct.pack(">HH", 2, 2))
        assert program.receive()[:2] == (1, 0)
        program.send(2, LISTEN, offset=CLAIMED, length=0x100)
        assert program.receive()[:2] == (2, 0)
        seen: list[tuple[int, ...]] = []

        def answer() -> None:
            # The request pushed as section 8's record; the answer: its offset, doubled.
            number, status, record = program.receive()
            fields = struct.unpack(">IBBHHHQI", record[:24])
            handle, tcode, _, _, source, _, offset, length = fields
            seen.append((number, status, tcode, source & 0x3F, offset, length))
            value = ((offset - CLAIMED) * 2).to_bytes(4, "big")
            program.send(3, RESPOND, offset=handle, ext=0, data=value)

        with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as other:
            generation, members = other.table()
            adapter = next(phy for phy, m in enumerate(members) if m.pid == bus.adapter_pid)
            me = next(phy for phy, m in enumerate(members) if m.pid == os.getpid())
            # The adapter's ROM over the bus: an IEEE 1212 bus-info block, "1394".
            header = other.read_quadlet(adapter, CSR + 0x400, generation=generation)
            assert header >> 24 == 4
            name = other.read_quadlet(adapter, CSR + 0x404, generation=generation)
            assert name == int.from_bytes(b"1394", "big")
            block = other.read_block(adapter, CSR + 0x400, 20, generation=generation)
            assert block[:8] == header.to_bytes(4, "big") + b"1394"
            # STATE_SET then STATE_CLEAR, read back through STATE_CLEAR.
            other.write_quadlet(adapter, CSR + 0x004, 0x300, generation=generation)
            other.write_quadlet(adapter, CSR + 0x000, 0x100, generation=generation)
            assert other.read_quadlet(adapter, CSR + 0x000, generation=generation) == 0x200
            # A claimed range: the program's answer comes back as a split response.
            thread = threading.Thread(target=answer)
            thread.start()
            value = other.read_quadlet(adapter, CLAIMED + 0x24, generation=generation)
            thread.join(20)
            assert value == 0x48
            # A quadlet read (tcode 4) from this host, pushed as a reply to listen #2.
            assert seen == [(2, 0, 4, me, CLAIMED + 0x24, 4)]
            # Outside every range and register: an address error.
            with pytest.raises(Exception, match="address"):
                other.read_quadlet(adapter, 0x2_0000_0000, generation=generation)
        program.sock.close()
