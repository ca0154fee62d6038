"""The adapter protocol's bytes and generation pinning, against docs/host-adapter.md.

The layouts below are written from the document's tables, not taken from
``fw1394.transport.host_adapter.protocol``: the module's encoder and decoder are
checked against them, and a client made of them alone speaks to a live
adapter over its Unix socket.
"""

from __future__ import annotations

import socket
import struct
from collections.abc import Iterator

import pytest
from adapter_support import AdapterBus, adapter_bus
from hypothesis import given
from hypothesis import strategies as st

from fw1394.host.bus_port import BusPort
from fw1394.transport.host_adapter.protocol import (
    Op,
    Reply,
    Request,
    Status,
    parse_reply,
    parse_request,
)
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.runtime import adapter_socket

# -- the document's layouts ---------------------------------------------------------------
#: Section 3: request, op, node, extended_tcode, generation, offset, length, quadlet, wait.
REQUEST_HEAD = struct.Struct(">IBBHIQIBf")
#: Section 4: request, status, generation, phy, ack, rcode, outcome_unknown.
REPLY_HEAD = struct.Struct(">IBIBbbB")
U32 = struct.Struct(">I")
OPS = {"info": 0, "read": 1, "write": 2, "lock": 3, "send": 4, "hello": 5}
STATUSES = {"ok": 0, "failed": 1, "refused": 2, "stale": 3}


def request_bytes(
    number: int,
    op: str,
    *,
    node: int = 0,
    extended_tcode: int = 0,
    generation: int = 0,
    offset: int = 0,
    length: int = 0,
    quadlet: bool = False,
    wait: float = 0.0,
    argument: bytes = b"",
    data: bytes = b"",
) -> bytes:
    """A whole frame (length prefix included) as section 3 lays it out."""
    body = REQUEST_HEAD.pack(
        number, OPS[op], node, extended_tcode, generation, offset, length, quadlet, wait
    )
    body += U32.pack(len(argument)) + argument + U32.pack(len(data)) + data
    return U32.pack(len(body)) + body


def reply_fields(body: bytes) -> dict[str, object]:
    """A reply body read as section 4 lays it out."""
    number, status, generation, phy, ack, rcode, unknown = REPLY_HEAD.unpack_from(body)
    at = REPLY_HEAD.size
    reason = body[at + 1 : at + 1 + body[at]].decode()
    at += 1 + body[at]
    (detail_size,) = struct.unpack_from(">H", body, at)
    detail = body[at + 2 : at + 2 + detail_size].decode()
    at += 2 + detail_size
    (data_size,) = U32.unpack_from(body, at)
    data = body[at + 4 : at + 4 + data_size]
    assert at + 4 + data_size == len(body), "bytes after the data"
    return {
        "request": number,
        "status": status,
        "generation": generation,
        "phy": phy,
        "ack": ack,
        "rcode": rcode,
        "outcome_unknown": unknown,
        "reason": reason,
        "detail": detail,
        "data": data,
    }


# -- the module against the document --------------------------------------------------------
@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from(sorted(OPS)),
    st.integers(0, 63),
    st.integers(0, 0xFFFF),
    st.integers(0, 2**32 - 1),
    st.integers(0, 2**48 - 1),
    st.integers(0, 2**32 - 1),
    st.booleans(),
    st.sampled_from([0.0, 0.5, 2.25]),
    st.binary(max_size=8),
    st.binary(max_size=40),
)
def test_requests_are_the_documented_bytes(
    number: int,
    op: str,
    node: int,
    extended_tcode: int,
    generation: int,
    offset: int,
    length: int,
    quadlet: bool,
    wait: float,
    argument: bytes,
    data: bytes,
) -> None:
    fields = {
        "node": node,
        "extended_tcode": extended_tcode,
        "generation": generation,
        "offset": offset,
        "length": length,
        "quadlet": quadlet,
        "wait": wait,
        "argument": argument,
        "data": data,
    }
    expected = request_bytes(number, op, **fields)  # type: ignore[arg-type]
    request = Request(number, Op(OPS[op]), **fields)  # type: ignore[arg-type]
    assert request.pack() == expected
    assert parse_request(expected[4:]) == request


@given(
    st.integers(0, 2**32 - 1),
    st.sampled_from(sorted(STATUSES)),
    st.integers(0, 2**32 - 1),
    st.integers(0, 255),
    st.integers(-1, 15),
    st.integers(-1, 15),
    st.booleans(),
    st.text(max_size=20),
    st.text(max_size=60),
    st.binary(max_size=40),
)
def test_replies_are_the_documented_bytes(
    number: int,
    status: str,
    generation: int,
    phy: int,
    ack: int,
    rcode: int,
    unknown: bool,
    reason: str,
    detail: str,
    data: bytes,
) -> None:
    reply = Reply(
        number, Status(STATUSES[status]), generation, phy, ack, rcode, unknown, reason, detail, data
    )
    frame = reply.pack()
    (size,) = U32.unpack_from(frame)
    assert size == len(frame) - 4
    assert reply_fields(frame[4:]) == {
        "request": number,
        "status": STATUSES[status],
        "generation": generation,
        "phy": phy,
        "ack": ack,
        "rcode": rcode,
        "outcome_unknown": int(unknown),
        "reason": reason,
        "detail": detail,
        "data": data,
    }
    assert parse_reply(frame[4:]) == reply


# -- a client made of the document, on a live adapter ---------------------------------------
class DocClient:
    """Speaks section 1-4 bytes over the adapter's socket, nothing from fw1394."""

    def __init__(self, bus: AdapterBus) -> None:
        self.sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self.sock.settimeout(10.0)
        self.sock.connect(str(adapter_socket(bus.directory)))
        self.buffer = b""

    def ask(self, number: int, op: str, **fields: object) -> dict[str, object]:
        self.sock.sendall(request_bytes(number, op, **fields))  # type: ignore[arg-type]
        reply = self.next_reply()
        assert reply is not None, "the adapter closed the connection instead of replying"
        assert reply["request"] == number
        return reply

    def next_reply(self) -> dict[str, object] | None:
        while len(self.buffer) < 4 or len(self.buffer) < 4 + U32.unpack_from(self.buffer)[0]:
            chunk = self.sock.recv(1 << 16)
            if not chunk:
                return None
            self.buffer += chunk
        (size,) = U32.unpack_from(self.buffer)
        body, self.buffer = self.buffer[4 : 4 + size], self.buffer[4 + size :]
        return reply_fields(body)

    def closed(self) -> bool:
        return self.next_reply() is None

    def close(self) -> None:
        self.sock.close()


HELLO_V2 = struct.pack(">HH", 2, 2)


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("gen", 2) as running:
        yield running


@pytest.mark.process
def test_a_connection_starts_with_hello(bus: AdapterBus) -> None:
    early = DocClient(bus)
    try:
        refused = early.ask(7, "info")
        assert refused["status"] == STATUSES["refused"]
        assert "hello" in str(refused["detail"])
        assert early.closed()
    finally:
        early.close()
    old = DocClient(bus)
    try:
        refused = old.ask(1, "hello", data=struct.pack(">HH", 1, 1))
        assert refused["status"] == STATUSES["refused"]
        assert "2" in str(refused["detail"])
        assert old.closed()
    finally:
        old.close()
    client = DocClient(bus)
    try:
        chosen = client.ask(1, "hello", data=struct.pack(">HH", 1, 9))
        assert chosen["status"] == STATUSES["ok"] and chosen["data"] == struct.pack(">H", 2)
        again = client.ask(2, "hello", data=HELLO_V2)
        assert again["status"] == STATUSES["refused"]
        info = client.ask(3, "info")
        assert info["status"] == STATUSES["ok"]
        data = info["data"]
        assert isinstance(data, bytes)
        _, count, _ = struct.unpack_from(">IHH", data)
        assert len(data) == 8 + 24 * count and count == 3  # two nodes and the adapter
    finally:
        client.close()


@pytest.mark.process
def test_a_request_of_an_ended_generation_is_never_sent(bus: AdapterBus) -> None:
    client = DocClient(bus)
    try:
        assert client.ask(1, "hello", data=HELLO_V2)["status"] == STATUSES["ok"]
        before = client.ask(2, "info")["generation"]
        assert isinstance(before, int)
        value = (0x600D).to_bytes(4, "big")
        written = client.ask(
            3, "write", node=0, offset=0x700, quadlet=True, data=value, generation=before
        )
        assert written["status"] == STATUSES["ok"], written["detail"]
        # A second host joining the bus is a bus reset: generation `before` ends.
        with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as other:
            other.wait_ready()
            assert other.generation > before
            late = (0xBAD).to_bytes(4, "big")
            for number, op, fields in (
                (4, "write", {"quadlet": True, "data": late}),
                (5, "read", {"quadlet": True, "length": 4}),
                (6, "write", {"data": late + late}),
                (7, "lock", {"extended_tcode": 3, "data": late}),
                (8, "send", {"data": bytes(16), "wait": 0.2}),
            ):
                stale = client.ask(number, op, node=0, offset=0x700, generation=before, **fields)
                assert stale["status"] == STATUSES["stale"], (op, stale)
                assert stale["data"] == U32.pack(before)
                assert isinstance(stale["generation"], int) and stale["generation"] > before
                assert "not sent" in str(stale["detail"])
            now = client.ask(9, "info")["generation"]
            read = client.ask(
                10, "read", node=0, offset=0x700, quadlet=True, length=4, generation=now
            )
            assert read["status"] == STATUSES["ok"], read["detail"]
            assert read["data"] == value  # the stale writes never reached the node
            assert other.read_quadlet(0, 0x700, generation=other.generation) == 0x600D
    finally:
        client.close()


@pytest.mark.process
def test_bus_port_calls_pinned_to_an_ended_generation_send_nothing(bus: AdapterBus) -> None:
    from fw1394.host.bus_port import StaleGenerationError

    with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as port:
        port.wait_ready()
        old = port.generation
        port.write_quadlet(1, 0x40, 0x1111, generation=old)
        port.reset()
        assert port.generation > old
        calls = (
            lambda: port.write_quadlet(1, 0x40, 0x2222, generation=old),
            lambda: port.write_block(1, 0x40, b"\0\0\x22\x22", generation=old),
            lambda: port.read_quadlet(1, 0x40, generation=old),
            lambda: port.read_block(1, 0x40, 8, generation=old),
            lambda: port.lock(1, 0x40, 3, b"", b"\0\0\0\1", generation=old),
        )
        for call in calls:
            with pytest.raises(StaleGenerationError) as stale:
                call()
            assert stale.value.reason.value == "bus_reset"
            assert (stale.value.addressed, stale.value.current) == (old, port.generation)
        assert port.read_quadlet(1, 0x40, generation=port.generation) == 0x1111
