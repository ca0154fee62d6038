"""The adapter's one-pass transactions, and their handover to the engine, on a live bus.

A client written from ``docs/host-adapter.md`` alone (sections 1-4, nothing
from fw1394) drives a bus of memory nodes the way a real-time host loop does:
one blocking transaction after another, which the adapter runs on its express
path (``fw1394.transport.host_adapter.express``). The truth is what memory
does: a read returns what the last write put there. The express path hands a
transaction to the engine when anything else happens first: requests piled up
by several clients at once, a node that never answers (its ack timeout).
"""

from __future__ import annotations

import random
import socket
import struct
from collections.abc import Iterator

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.transport.supervision.runtime import adapter_socket

#: Section 3: request, op, node, extended_tcode, generation, offset, length, quadlet, wait.
REQUEST_HEAD = struct.Struct(">IBBHIQIBf")
#: Section 4: request, status, generation, phy, ack, rcode, outcome_unknown.
REPLY_HEAD = struct.Struct(">IBIBbbB")
U32 = struct.Struct(">I")
INFO, READ, WRITE, HELLO = 0, 1, 2, 5
OK, FAILED = 0, 1
#: Section 3's info table: u32 initiator, u16 count, u16 reserved, 24-byte entries.
TABLE_HEAD = struct.Struct(">IHH")
ENTRY_SIZE = 24
HOST_FLAG = 2


class Client:
    """Section 1-4 bytes over the adapter's socket."""

    def __init__(self, bus: AdapterBus) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(10.0)
        self.sock.connect(str(adapter_socket(bus.directory)))
        self.buffer = b""
        self.number = 0
        self.generation = 0
        assert self.ask(HELLO, data=struct.pack(">HH", 2, 2))["status"] == OK

    def send(self, op: int, **fields: int | bytes) -> int:
        self.number += 1
        data = fields.get("data", b"")
        assert isinstance(data, bytes)
        head = REQUEST_HEAD.pack(
            self.number,
            op,
            fields.get("node", 0),
            0,
            self.generation,
            fields.get("offset", 0),
            fields.get("length", 0),
            fields.get("quadlet", 0),
            0.0,
        )
        body = head + U32.pack(0) + U32.pack(len(data)) + data
        self.sock.sendall(U32.pack(len(body)) + body)
        return self.number

    def reply(self) -> dict[str, int | bytes | str]:
        while len(self.buffer) < 4 or len(self.buffer) < 4 + U32.unpack_from(self.buffer)[0]:
            chunk = self.sock.recv(1 << 16)
            assert chunk, "the adapter closed the connection"
            self.buffer += chunk
        (size,) = U32.unpack_from(self.buffer)
        body, self.buffer = self.buffer[4 : 4 + size], self.buffer[4 + size :]
        number, status, generation, _, _, rcode, _ = REPLY_HEAD.unpack_from(body)
        at = REPLY_HEAD.size
        reason = body[at + 1 : at + 1 + body[at]].decode()
        at += 1 + body[at]
        at += 2 + struct.unpack_from(">H", body, at)[0]
        (data_size,) = U32.unpack_from(body, at)
        self.generation = generation
        return {
            "request": number,
            "status": status,
            "rcode": rcode,
            "reason": reason,
            "data": body[at + 4 : at + 4 + data_size],
        }

    def ask(self, op: int, **fields: int | bytes) -> dict[str, int | bytes | str]:
        number = self.send(op, **fields)
        answer = self.reply()
        assert answer["request"] == number
        return answer

    def nodes(self) -> list[int]:
        """Physical IDs of the bus's nodes (the host members left out)."""
        table = self.ask(INFO)["data"]
        assert isinstance(table, bytes)
        _, count, _ = TABLE_HEAD.unpack_from(table)
        flags = [table[TABLE_HEAD.size + ENTRY_SIZE * k + 12] for k in range(count)]
        return [phy for phy, flag in enumerate(flags) if not flag & HOST_FLAG]

    def close(self) -> None:
        self.sock.close()


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("express", 2) as running:
        yield running


@pytest.mark.process
def test_a_real_time_loop_reads_back_what_it_wrote(bus: AdapterBus) -> None:
    client = Client(bus)
    try:
        nodes = client.nodes()
        assert len(nodes) == 2
        shadow = {node: bytearray(64) for node in nodes}
        pick = random.Random(29)
        for cycle in range(60):
            for node in nodes:
                if cycle % 3 == 2:  # a quadlet now and then: the other two kinds
                    value = pick.randbytes(4)
                    at = 4 * pick.randrange(16)
                    done = client.ask(WRITE, node=node, offset=at, quadlet=1, data=value)
                    shadow[node][at : at + 4] = value
                    read = client.ask(READ, node=node, offset=at, length=4, quadlet=1)
                    assert (done["status"], read["status"]) == (OK, OK)
                    assert read["data"] == value
                    continue
                block = pick.randbytes(16)
                at = 16 * pick.randrange(4)
                done = client.ask(WRITE, node=node, offset=at, length=16, data=block)
                shadow[node][at : at + 16] = block
                read = client.ask(READ, node=node, offset=0, length=64)
                assert (done["status"], read["status"]) == (OK, OK)
                assert read["data"] == bytes(shadow[node])
    finally:
        client.close()


@pytest.mark.process
def test_requests_piled_up_by_two_clients_all_end_right(bus: AdapterBus) -> None:
    first, second = Client(bus), Client(bus)
    try:
        nodes = first.nodes()
        second.nodes()
        # Each client writes its own quadlets, many at once, then reads them back
        # many at once: the first of each burst may go the express way, the rest
        # the engine's, and the bursts of the two clients interleave.
        for client, base in ((first, 0x200), (second, 0x300)):
            for k in range(24):
                data = struct.pack(">I", base + k)
                client.send(WRITE, node=nodes[k % 2], offset=base + 4 * k, quadlet=1, data=data)
        for client in (first, second):
            assert all(client.reply()["status"] == OK for _ in range(24))
        asked: dict[tuple[Client, int | bytes | str], bytes] = {}
        for client, base in ((first, 0x200), (second, 0x300)):
            for k in range(24):
                number = client.send(READ, node=nodes[k % 2], offset=base + 4 * k, quadlet=1)
                asked[client, number] = struct.pack(">I", base + k)
        for client in (first, second):
            for _ in range(24):
                answer = client.reply()
                assert answer["status"] == OK
                assert answer["data"] == asked[client, answer["request"]]
    finally:
        first.close()
        second.close()


@pytest.mark.process
def test_a_node_that_never_answers_fails_no_ack_and_the_loop_goes_on(bus: AdapterBus) -> None:
    client = Client(bus)
    try:
        nodes = client.nodes()
        nobody = 40  # no member has this physical ID
        client.ask(WRITE, node=nodes[0], offset=0x400, quadlet=1, data=b"\x00\x00\x01\x00")
        missing = client.ask(READ, node=nobody, offset=0x400, quadlet=1)
        assert missing["status"] == FAILED and missing["reason"] == "no_ack"
        again = client.ask(READ, node=nodes[0], offset=0x400, quadlet=1)
        assert again["status"] == OK and again["data"] == b"\x00\x00\x01\x00"
    finally:
        client.close()


@pytest.mark.process
def test_late_copies_of_earlier_answers_never_end_a_later_read() -> None:
    # The node sends a share of its answers twice and delays a share: one blocking
    # read after another (the express path) may meet a copy of an earlier answer,
    # with the same label, before its own.
    options = ("--duplicate", "0.3", "--delay", "0.3", "--delay-time", "0.0005")
    with adapter_bus("late-copies", 1, node_options=options) as bus:
        client = Client(bus)
        try:
            node = client.nodes()[0]
            words = [struct.pack(">I", 0x1394_0000 + k) for k in range(32)]
            for k, word in enumerate(words):
                assert (
                    client.ask(WRITE, node=node, offset=4 * k, quadlet=1, data=word)["status"] == OK
                )
            got = [
                client.ask(READ, node=node, offset=4 * (k % 32), quadlet=1)["data"]
                for k in range(400)
            ]
            assert got == [words[k % 32] for k in range(400)]
        finally:
            client.close()
