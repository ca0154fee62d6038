"""The virtual bus with real processes and sockets on loopback."""

from __future__ import annotations

import json
import os
import signal
import time
from pathlib import Path

import pytest
from bus_support import PREFIX, LaunchBus, bus_name, start_node, stop, wait_until_gone
from polling import wait_until

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.record import RecordType
from fw1394.cli.main import main
from fw1394.engine import FailureReason, ReadCompleted, TransactionFailed
from fw1394.engine.faults import FaultConfig
from fw1394.host.bus_port import BusPort
from fw1394.packets import AckCode, SelfIdPacket, decode
from fw1394.transport.bus_host import TransactionError
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.launch import LaunchedBus

# Timeouts are generous (1 s): this machine sometimes stalls a round trip for milliseconds.
FAST_TIMING = Timing(heartbeat=0.1, lease=2.0)
FAST_ARGS = ("--heartbeat", "0.1", "--lease", "2.0")


@pytest.fixture
def bus3(launch_bus: LaunchBus) -> LaunchedBus:
    return launch_bus(3, tag="three", node_arguments=FAST_ARGS)


def host(bus: LaunchedBus, ack_timeout: float = 1.0) -> BusPort:
    return port_on(bus.config, ack_timeout)


def port_on(config: BusConfig, ack_timeout: float = 1.0) -> BusPort:
    return BusPort(config, timing=FAST_TIMING, ack_timeout=ack_timeout, split_timeout=1.0)


@pytest.mark.process
def test_read_and_write_every_node(bus3: LaunchedBus) -> None:
    with host(bus3) as port:
        nodes = port.nodes()
        assert [phy for phy, _ in nodes] == [0, 1, 2]
        assert [m.board_id for _, m in nodes] == [0, 1, 2]
        assert port.phy_id == 3  # the host is root
        for phy, _ in nodes:
            port.write_quadlet(phy, 0x10, 0xC0DE0000 + phy)
            block = bytes(range(256)) * 8
            port.write_block(phy, 0x100, block)
        for phy, _ in nodes:
            assert port.read_quadlet(phy, 0x10) == 0xC0DE0000 + phy
            assert port.read_block(phy, 0x100, 2048) == bytes(range(256)) * 8
        port.write_quadlet(63, 0x20, 0xB0AD)  # broadcast: nobody acks, everyone stores
        wait_until(
            lambda: [port.read_quadlet(phy, 0x20) for phy, _ in nodes] == [0xB0AD] * 3,
            timeout=5,
        )
        with pytest.raises(TransactionError, match="address_error"):
            port.read_quadlet(0, 0x1_0000_0000)
        assert port.lock(1, 0x10, 2, (0xC0DE0001).to_bytes(4, "big"), bytes(4)) == bytes.fromhex(
            "c0de0001"
        )


@pytest.mark.process
def test_tap_sees_resets_self_ids_packets_and_acks(bus3: LaunchedBus) -> None:
    with BusTap(bus3.config.name, ack_wait=0.5) as tap, host(bus3) as port:
        port.nodes()
        assert port.read_quadlet(2, 0) == 0
        generation = port.generation
        records = []
        while (record := tap.receive(0.3)) is not None:
            records.append(record)
    resets = [r for r in records if r.record_type is RecordType.bus_reset]
    assert resets and resets[-1].generation == generation
    self_ids = [
        decode(r.data)
        for r in records
        if r.record_type is RecordType.phy_packet and r.generation == generation
    ]
    assert sorted(p.phy_id for p in self_ids if isinstance(p, SelfIdPacket)) == [0, 1, 2, 3]
    packets = [r for r in records if r.record_type is RecordType.async_packet]
    request, response = packets[-2], packets[-1]
    assert request.sender == 3 and request.ack == AckCode.ack_pending
    assert response.sender == 2 and response.ack == AckCode.ack_complete
    assert [r.data[0] >> 4 for r in records if r.record_type is RecordType.ack][-2:] == [
        AckCode.ack_pending,
        AckCode.ack_complete,
    ]
    stamps = [r.timestamp_ns for r in records]
    assert stamps == sorted(stamps)


@pytest.mark.process
def test_a_killed_node_resets_the_bus_and_can_come_back(bus3: LaunchedBus) -> None:
    victim = bus3.records()[1].pid
    with host(bus3, ack_timeout=10.0) as port:
        port.nodes()
        before = port.generation
        os.kill(victim, signal.SIGSTOP)  # it can no longer ack: the read stays outstanding
        tid = port.start_read_quadlet(1, 0)
        os.kill(victim, signal.SIGKILL)
        started = time.monotonic()
        event = port.wait(tid)
        assert isinstance(event, TransactionFailed) and event.reason is FailureReason.bus_reset
        # Ended by the reset (process check or the 2 s lease), long before the ack timeout.
        assert time.monotonic() - started < 5.0
        assert [m.board_id for _, m in port.nodes()] == [0, 2]
        assert port.generation > before
        comeback = start_node(bus3.config.name, 1, *FAST_ARGS)
        try:
            limit = time.monotonic() + 20
            while len(port.nodes()) < 3 and time.monotonic() < limit:
                port.poll(0.05)
            assert [m.board_id for _, m in port.nodes()] == [0, 1, 2]
            port.write_quadlet(1, 0, 7)
            assert port.read_quadlet(1, 0) == 7
        finally:
            stop(comeback)


@pytest.mark.process
@pytest.mark.slow
def test_five_percent_loss_never_hangs_a_transaction(launch_bus: LaunchBus) -> None:
    lossy = (*FAST_ARGS, "--loss", "0.05", "--duplicate", "0.02", "--delay", "0.05")
    bus = launch_bus(2, tag="lossy", node_arguments=lossy)
    faults = FaultConfig(loss=0.05, seed=1)
    with BusPort(
        bus.config, timing=FAST_TIMING, faults=faults, ack_timeout=0.2, split_timeout=0.2
    ) as port:
        port.nodes()
        outcomes: dict[str, int] = {}
        started = time.monotonic()
        for i in range(300):
            tid = port.start_read_quadlet(i % 2, 0)
            event = port.wait(tid)
            name = "ok" if isinstance(event, ReadCompleted) else "?"
            if isinstance(event, TransactionFailed):
                name = str(event.reason)
            outcomes[name] = outcomes.get(name, 0) + 1
        elapsed = time.monotonic() - started
    assert outcomes.get("ok", 0) > 250, outcomes
    assert sum(outcomes.values()) == 300
    assert elapsed < 30, (elapsed, outcomes)
    assert set(outcomes) <= {"ok", "no_ack", "response_timeout", "bus_reset"}, outcomes


@pytest.mark.process
def test_two_buses_side_by_side(tmp_path: Path) -> None:
    first, second = BusConfig(bus_name("left")), BusConfig(bus_name("right"))
    with (
        LaunchedBus(first, 1, root=tmp_path, node_arguments=FAST_ARGS) as a,
        LaunchedBus(second, 1, root=tmp_path, node_arguments=FAST_ARGS) as b,
    ):
        a.wait_members()
        b.wait_members()
        with BusTap(second.name) as tap_b:
            with port_on(first) as left:
                left.write_quadlet(0, 0, 0x1111)
                assert left.read_quadlet(0, 0) == 0x1111
            heard = []
            while (record := tap_b.receive(0.2)) is not None:
                heard.append(record)
        assert heard == []  # bus A's traffic never reached bus B
        with port_on(second) as right:
            assert right.read_quadlet(0, 0) == 0


@pytest.mark.process
def test_cli_bus_lifecycle(capsys: pytest.CaptureFixture[str]) -> None:
    name = bus_name("cli")
    try:
        assert main(["bus", "up", "--name", name, "--nodes", "2", *FAST_ARGS]) == 0
        table = capsys.readouterr().out.splitlines()
        assert table[0].split() == ["PHY", "ROLE", "KIND", "GEN", "BOARD", "PID", "ADDRESS"]
        # The two nodes, then the bus's host adapter.
        assert [row.split()[:3] for row in table[1:]] == [
            ["0", "node", "memory"],
            ["1", "node", "memory"],
            ["2", "adapter", "-"],
        ]
        assert main(["write", "--name", name, "1", "0x40", "0xabc"]) == 0
        assert main(["read", "--name", name, "1", "0x40", "--json"]) == 0
        assert '"data": "00000abc"' in capsys.readouterr().out
        assert main(["read", "--name", name, "1", "0x40", "--length", "8"]) == 0
        assert capsys.readouterr().out.strip() == "00000abc 00000000"
        assert main(["lock", "--name", name, "1", "0x40", "fetch_add", "1"]) == 0
        assert capsys.readouterr().out.strip() == "00000abc"
        assert main(["read", "--name", name, "1", "0x3"]) == 1
        assert "address_error" in capsys.readouterr().err
        assert main(["read", "--name", name, "1", "0x3", "--json"]) == 1
        failed = json.loads(capsys.readouterr().out)
        assert failed["error"] == {"reason": "rcode_error", "rcode": "resp_address_error"}
        assert main(["read", "--name", name, "9", "0x0"]) == 2
        assert "no node 9" in capsys.readouterr().err
        assert main(["bus", "status", "--name", name]) == 0
        assert "3 members" in capsys.readouterr().out
        assert main(["bus", "reset", "--name", name]) == 0
        assert "->" in capsys.readouterr().out
        # Bringing it up again is refused, and the running bus is left as it was.
        assert main(["bus", "up", "--name", name, "--nodes", "1", *FAST_ARGS]) == 2
        assert "already up" in capsys.readouterr().err
        assert main(["bus", "status", "--name", name]) == 0
        assert "3 members" in capsys.readouterr().out
    finally:
        assert main(["bus", "down", "--name", name]) == 0
    assert wait_until_gone(name) == []
    assert main(["bus", "down", "--name", name]) == 2
    assert "no bus" in capsys.readouterr().err


def test_cli_rejects_bad_input_without_tracebacks(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["bus", "up", "--name", "bad name!", "--nodes", "1"]) == 2
    assert main(["bus", "up", "--name", bus_name("x"), "--nodes", "64"]) == 2
    assert main(["bus", "up", "--name", bus_name("x"), "--nodes", "1", "--loss", "2"]) == 2
    assert main(["bus", "up", "--name", bus_name("x"), "--nodes", "1", "--board", "nope"]) == 2
    assert main(["write", "0", "0x0", "0x1ffffffff"]) == 2
    assert main(["lock", "0", "0x0", "compare_swap", "1"]) == 2
    # Lengths the 1394 field allows but one datagram cannot carry.
    assert main(["read", "0", "0x0", "--length", "65535"]) == 2
    assert main(["write", "0", "0x0", *["0x0"] * 16_365]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and err.count("fw1394: error:") == 8
    assert "outside 1..65448" in err and "at most 65456" in err


@pytest.mark.process
def test_no_process_is_left_behind() -> None:
    assert wait_until_gone(PREFIX) == []


@pytest.mark.process
def test_a_response_too_large_for_a_datagram_is_dropped_not_fatal(tmp_path: Path) -> None:
    """A 65,535-byte block read: the board answers, no datagram can carry it.

    The node must ack the request, report the dropped response on stderr and go
    on serving; the host refuses such a read before it reaches the bus.
    """
    import subprocess

    from bus_support import node_command

    from fw1394.packets import BlockReadRequest
    from fw1394.packets.fast import encode_packet
    from fw1394.transport.bus_host import LOCAL_BUS, MAX_BLOCK_READ
    from fw1394.transport.sansio.wire import FrameKind

    name = bus_name("oversize")
    log = tmp_path / "node.log"
    with open(log, "wb") as errors:
        node = subprocess.Popen(
            node_command(name, 0, "--memory-size", str(1 << 17), *FAST_ARGS),
            stdin=subprocess.DEVNULL,
            stderr=errors,
        )
    try:
        with port_on(BusConfig(name)) as port:
            limit = time.monotonic() + 30
            while not port.nodes() and time.monotonic() < limit:
                port.poll(0.05)
            with pytest.raises(ValueError, match="one datagram"):
                port.start_read_block(0, 0, MAX_BLOCK_READ + 1)
            assert len(port.read_block(0, 0, MAX_BLOCK_READ)) == MAX_BLOCK_READ
            # Past the host's guard, as a fuzzer or foreign host would send it.
            assert port.phy_id is not None
            me = LOCAL_BUS << 6 | port.phy_id
            request = BlockReadRequest(
                destination_id=LOCAL_BUS << 6, tlabel=5, source_id=me, offset=0, data_length=65535
            )
            sequence = port.station.send(int(FrameKind.async_packet), 0, encode_packet(request))
            acked = None
            limit = time.monotonic() + 2.0
            while acked is None and time.monotonic() < limit:
                frame = port.station.receive()
                if frame is not None and frame[0].kind == FrameKind.ack:
                    acked = frame
            assert acked is not None, "the oversized request was never acked"
            _, payload = acked
            assert payload[0] >> 4 == AckCode.ack_pending
            assert int.from_bytes(payload[4:8], "big") == sequence
            assert len(payload) == 8  # the ack alone: its response could not follow
            assert node.poll() is None, "the node died"
            port.write_quadlet(0, 0x10, 0x600DF00D)
            assert port.read_quadlet(0, 0x10) == 0x600DF00D
    finally:
        stop(node)
    assert "response to node" in log.read_text() and "65507-byte" in log.read_text()
