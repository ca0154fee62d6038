"""The host adapter: one host member per bus that programs share without bus resets.

Real processes on loopback multicast: node processes and the adapter started
as ``fw1394 bus up`` starts them, clients over the adapter's Unix socket, a
second host member making traffic, and ``fw1394`` commands as subprocesses.
The bus generation, read from the coordinator's beacons, is the witness that
attaching and detaching reset nothing.
"""

from __future__ import annotations

import stat
import subprocess
import sys
import threading
import time

import pytest
from adapter_support import AdapterBus, adapter_bus
from hypothesis import given
from hypothesis import strategies as st

from fw1394.engine import FailureReason
from fw1394.host.adapter_port import AdapterPort
from fw1394.packets import AckCode, QuadletReadRequest, QuadletReadResponse, decode, encode
from fw1394.packets.nodeid import node_id
from fw1394.transport.bus_host import TransactionError
from fw1394.transport.host_adapter.protocol import (
    FrameBuffer,
    Op,
    Reply,
    Request,
    Status,
    parse_reply,
    parse_request,
)
from fw1394.transport.supervision.observe import watch
from fw1394.transport.supervision.runtime import adapter_socket

# -- the protocol, in process ------------------------------------------------------------


@given(
    st.lists(
        st.builds(
            Request,
            st.integers(0, 2**32 - 1),
            st.sampled_from(Op),
            st.integers(0, 63),
            st.integers(0, 2**48 - 1),
            st.integers(0, 2**32 - 1),
            st.booleans(),
            st.integers(0, 0xFFFF),
            st.just(0.25),
            st.binary(max_size=16),
            st.binary(max_size=64),
            st.integers(0, 2**32 - 1),
        ),
        min_size=1,
        max_size=5,
    ),
    st.integers(1, 40),
)
def test_requests_survive_any_split_of_the_stream(requests: list[Request], chunk: int) -> None:
    stream = b"".join(request.pack() for request in requests)
    frames = FrameBuffer()
    bodies = []
    for start in range(0, len(stream), chunk):
        bodies += frames.feed(stream[start : start + chunk])
    assert [parse_request(body) for body in bodies] == requests


@given(
    st.builds(
        Reply,
        st.integers(0, 2**32 - 1),
        st.sampled_from(Status),
        st.integers(0, 2**32 - 1),
        st.integers(0, 255),
        st.integers(-1, 15),
        st.integers(-1, 15),
        st.booleans(),
        st.text(max_size=30),
        st.text(max_size=200),
        st.binary(max_size=100),
    )
)
def test_replies_round_trip(reply: Reply) -> None:
    (body,) = FrameBuffer().feed(reply.pack())
    assert parse_reply(body) == reply


# -- a real bus ---------------------------------------------------------------------------


@pytest.fixture(scope="module")
def memory_bus() -> object:
    with adapter_bus("adapter", 2) as bus:
        yield bus


TRAFFIC = """
import sys, time
from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
port = BusPort(BusConfig(sys.argv[1]), timing=Timing(heartbeat=0.1, lease=2.0))
port.wait_ready()
print("ready", flush=True)
count = 0
while True:
    count += 1
    port.write_quadlet(0, 0x100, count)
    port.read_quadlet(0, 0x100)
"""


@pytest.mark.process
def test_socket_is_private_and_the_adapter_is_a_host_member(memory_bus: AdapterBus) -> None:
    path = adapter_socket(memory_bus.directory)
    mode = path.stat().st_mode
    assert stat.S_ISSOCK(mode)
    assert stat.S_IMODE(mode) == 0o600
    members = memory_bus.view().members
    hosts = [m for m in members if m.host]
    assert [m.pid for m in hosts] == [memory_bus.adapter_pid]
    assert members[-1].pid == memory_bus.adapter_pid  # a contender: the highest ID, root


@pytest.mark.process
def test_reads_attach_and_detach_without_a_bus_reset_under_traffic(
    memory_bus: AdapterBus,
) -> None:
    traffic = subprocess.Popen(
        [sys.executable, "-c", TRAFFIC, memory_bus.name],
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert traffic.stdout is not None and traffic.stdout.readline() == "ready\n"
        time.sleep(0.3)  # the traffic member's join has settled
        before = memory_bus.view()
        with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
            port.write_quadlet(1, 0x40, 0xC0FFEE)
        # 100 programs' worth of attach, read, detach: the library in a loop...
        for _ in range(100):
            with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
                assert port.read_quadlet(1, 0x40) == 0xC0FFEE
                assert port.generation == before.generation
        # ...and the command itself, a process each time.
        for _ in range(5):
            result = memory_bus.fw1394("read", "1", "0x40")
            assert result.returncode == 0, result.stderr
            assert result.stdout == "00c0ffee\n"
        after = memory_bus.view()
        assert traffic.poll() is None, "the traffic member stopped"
        with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
            counter = port.read_quadlet(0, 0x100)
        assert counter > 0  # the other member's writes really went on meanwhile
    finally:
        traffic.terminate()
        traffic.wait(10)
        # Its leave is a bus reset: over before the next test uses the bus.
        watch(memory_bus.config, 10.0, lambda view: sum(m.host for m in view.members) == 1)
    assert after.generation == before.generation
    assert after.members == before.members


@pytest.mark.process
def test_clients_keep_many_transactions_outstanding(memory_bus: AdapterBus) -> None:
    with (
        AdapterPort(memory_bus.name, root=memory_bus.root) as first,
        AdapterPort(memory_bus.name, root=memory_bus.root) as second,
    ):
        writes = [
            first.start(Op.write, 0, 0x200 + 4 * i, quadlet=True, data=i.to_bytes(4, "big"))
            for i in range(40)
        ]
        for number in writes:
            first.result(number)
        # 80 reads outstanding at once from two clients: more than the 64 tlabels.
        asked = [
            (client, i, client.start(Op.read, 0, 0x200 + 4 * i, length=4, quadlet=True))
            for i in range(40)
            for client in (first, second)
        ]
        for client, i, number in reversed(asked):
            assert int.from_bytes(client.result(number), "big") == i
        block = first.read_block(0, 0x200, 160)
        assert block == b"".join(i.to_bytes(4, "big") for i in range(40))


@pytest.mark.process
def test_failures_keep_the_engine_reason(memory_bus: AdapterBus) -> None:
    with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
        with pytest.raises(TransactionError) as failed:
            port.read_quadlet(0, 0x1_0000_0000)  # beyond the 64 KiB of memory
        assert failed.value.reason is FailureReason.rcode_error
        assert "resp_address_error" in str(failed.value)


@pytest.mark.process
def test_send_returns_the_ack_and_the_response_it_drew(memory_bus: AdapterBus) -> None:
    with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
        port.write_quadlet(1, 0x80, 0x1234ABCD)
        me = port.phy_id
        assert me is not None
        request = QuadletReadRequest(
            destination_id=node_id(1), tlabel=9, source_id=node_id(me), offset=0x80
        )
        answer = port.send_packet(1, encode(request))
        assert answer.ack == AckCode.ack_pending  # the memory node's concatenated read
        response = decode(answer.data)
        assert isinstance(response, QuadletReadResponse)
        assert response.tlabel == 9 and response.quadlet_data == 0x1234ABCD
        # The same packet with its header CRC zeroed: IEEE 1394 ignores it.
        broken = encode(request)[:12] + bytes(4)
        silence = port.send_packet(1, broken, wait=0.3)
        assert silence.ack == -1 and silence.data == b""


@pytest.mark.process
def test_commands_and_a_second_host_member(memory_bus: AdapterBus) -> None:
    """The command attaches through the adapter; --own-member joins as its own host."""
    before = memory_bus.view().generation
    assert memory_bus.fw1394("write", "0", "0x300", "7").returncode == 0
    assert memory_bus.view().generation == before
    own = memory_bus.fw1394("read", "0", "0x300", "--own-member")
    assert own.returncode == 0 and own.stdout == "00000007\n", own.stderr
    assert memory_bus.view().generation >= before + 2  # joined and left: two resets


@pytest.mark.process
def test_two_clients_and_watch_share_one_adapter() -> None:
    with adapter_bus("share", 1, board="snake2010") as bus:
        before = bus.view()
        stop = threading.Event()
        done: list[int] = []

        def client() -> None:
            with AdapterPort(bus.name, root=bus.root) as port:
                while not stop.is_set():
                    port.read_quadlet(0, 0x0)  # the status register
                    done.append(1)

        threads = [threading.Thread(target=client) for _ in range(2)]
        for thread in threads:
            thread.start()
        try:
            shown = bus.fw1394("watch", "0", "--once", "--json")
        finally:
            stop.set()
            for thread in threads:
                thread.join(10)
        assert shown.returncode == 0, shown.stderr
        assert '"kind": "snake2010"' in shown.stdout
        assert len(done) > 10
        after = bus.view()
        assert after.generation == before.generation
        assert sum(m.host for m in after.members) == 1  # the adapter, no one else


@pytest.mark.process
def test_a_client_leaving_mid_transaction_harms_no_one(memory_bus: AdapterBus) -> None:
    for _ in range(3):
        leaver = AdapterPort(memory_bus.name, root=memory_bus.root)
        for i in range(30):
            leaver.start(Op.read, 0, 4 * i, length=4, quadlet=True)
        leaver.close()  # gone before any reply
    with AdapterPort(memory_bus.name, root=memory_bus.root) as port:
        port.write_quadlet(0, 0x500, 0x5EED)
        assert port.read_quadlet(0, 0x500) == 0x5EED
