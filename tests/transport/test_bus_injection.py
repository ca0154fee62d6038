"""Frames from a process without the bus key change nothing on a keyed bus.

A forger joins the bus's multicast group (its address follows from the public
bus name), learns the generation from a beacon and sends a quadlet write and a
reset request. On an insecure bus (what every bus was before keys) both take
effect; on a keyed bus both are dropped and counted, and so is a genuine frame
recorded and sent again.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

import pytest
from bus_support import bus_name, wait_until_gone

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.cli.main import main
from fw1394.host.bus_port import BusPort
from fw1394.transport.media.choice import open_medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.sansio.wire import FrameKind, parse_header
from fw1394.transport.supervision.bus_key import KEY_ENV, KEY_FILE_ENV, new_key
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.runtime import bus_dir, read_members

ARGS = ("--heartbeat", "0.1", "--lease", "2.0")
TIMING = Timing(heartbeat=0.1, lease=2.0)
OFFSET = 0x40

FORGER = r"""
import secrets, sys
from fw1394.packets import QuadletWriteRequest, encode
from fw1394.packets.nodeid import node_id
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.media.choice import open_medium
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, parse_header

config = BusConfig(sys.argv[1], key=b"")
medium = open_medium(config, poll_interval=0.02)
medium.filter_as_tap()
while True:  # the generation, from any beacon: headers are not secret
    raw = medium.receive()
    if raw is not None and parse_header(raw).kind == FrameKind.beacon:
        generation = parse_header(raw).generation
        break
me = secrets.randbits(32) or 1
write = QuadletWriteRequest(destination_id=node_id(0), tlabel=9, source_id=node_id(1),
                            offset=int(sys.argv[2]), quadlet_data=0xDEADBEEF)
frames = [
    FrameHeader(FrameKind.async_packet, config.tag, me, generation, 1, 0, sequence=1).pack()
    + encode(write),
    FrameHeader(FrameKind.reset_request, config.tag, me, generation, 0xFF, 0xFF, sequence=2).pack(),
]
for frame in frames:
    medium.send(frame)
medium.close()
print(generation)
"""


def forge(name: str, port: BusPort) -> int:
    """Run the forger; ``port`` keeps serving the bus meanwhile (a host silent for a
    lease, while a loaded machine starts the forger, would be dropped by a reset)."""
    environment = {k: v for k, v in os.environ.items() if k not in (KEY_ENV, KEY_FILE_ENV)}
    forger = subprocess.Popen(
        [sys.executable, "-c", FORGER, name, str(OFFSET)],
        env=environment,
        stdout=subprocess.PIPE,
        text=True,
    )
    limit = time.monotonic() + 30
    while forger.poll() is None and time.monotonic() < limit:
        port.poll(0.05)
    out, _ = forger.communicate(timeout=5)
    assert forger.returncode == 0
    return int(out)


def settle(port: BusPort, seconds: float = 0.6) -> None:
    limit = time.monotonic() + seconds
    while time.monotonic() < limit:
        port.poll(0.05)


@pytest.mark.parametrize("keyed", [False, True], ids=["insecure", "keyed"])
@pytest.mark.process
def test_a_forged_write_and_reset_change_nothing_on_a_keyed_bus(
    tmp_path: Path, keyed: bool
) -> None:
    config = BusConfig(bus_name("forge"))
    key = new_key() if keyed else None
    with LaunchedBus(config, 1, root=tmp_path, node_arguments=ARGS, key=key) as bus:
        bus.wait_members()
        with BusPort(bus.member_config, timing=TIMING) as port:
            port.write_quadlet(0, OFFSET, 0)
            before = port.generation
            assert forge(config.name, port) == before
            settle(port)
            value, after = port.read_quadlet(0, OFFSET), port.generation
            if not keyed:  # the bus as it was: anyone on the host can write and reset
                assert (value, after > before) == (0xDEADBEEF, True)
                return
            assert (value, after) == (0, before)
            assert port.station.dropped is not None
            # Two frames reached the host (the reset went to everyone; the write's
            # destination was node 0): it dropped the reset.
            assert port.station.dropped.forged == 1
            node_pid = bus.records()[0].pid
            limit = time.monotonic() + 5
            while time.monotonic() < limit:
                counts = {m.pid: m.forged for m in read_members(bus_dir(config.name))}
                if counts.get(node_pid) == 2:
                    break
                time.sleep(0.1)
            assert counts.get(node_pid) == 2  # the node: the write and the reset
    assert wait_until_gone(config.name) == []


@pytest.mark.process
def test_a_recorded_frame_sent_again_is_a_replay(tmp_path: Path) -> None:
    config = BusConfig(bus_name("replay"))
    key = new_key()
    with LaunchedBus(config, 1, root=tmp_path, node_arguments=ARGS, key=key) as bus:
        bus.wait_members()
        recorder = open_medium(config)
        recorder.filter_as_tap()
        try:
            with BusPort(bus.member_config, timing=TIMING) as port:
                port.nodes()
                while recorder.receive_queued() is not None:
                    pass
                port.write_quadlet(0, OFFSET, 0x1111)
                recorded = None
                while (raw := recorder.receive_queued()) is not None:
                    header = parse_header(raw)
                    if header.kind == FrameKind.async_packet and header.destination == 0:
                        recorded = raw
                assert recorded is not None
                port.write_quadlet(0, OFFSET, 0x2222)
                recorder.send(recorded)  # the write of 0x1111, exactly as the host sent it
                settle(port, 0.3)
                assert port.read_quadlet(0, OFFSET) == 0x2222
        finally:
            recorder.close()
        limit = time.monotonic() + 5
        pid = bus.records()[0].pid
        while time.monotonic() < limit:
            counts = {m.pid: (m.forged, m.replayed) for m in read_members(bus_dir(config.name))}
            if counts.get(pid) == (0, 1):
                break
            time.sleep(0.1)
        assert counts.get(pid) == (0, 1)


@pytest.mark.process
def test_the_tap_records_only_genuine_frames_and_status_shows_the_count(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = BusConfig(bus_name("tapforge"))
    key = new_key()
    with LaunchedBus(config, 1, root=tmp_path, node_arguments=ARGS, key=key) as bus:
        bus.wait_members()
        with BusTap(config.name, key=key) as tap, BusPort(bus.member_config, timing=TIMING) as port:
            port.write_quadlet(0, OFFSET, 5)
            forge(config.name, port)
            settle(port)
            records = []
            while (record := tap.receive(0.2)) is not None:
                records.append(record)
            assert tap.dropped is not None and tap.dropped.forged == 2
            assert not any(b"\xde\xad\xbe\xef" in r.data for r in records)
            # The genuine write of 5 is there: its packet's data quadlet follows the header.
            assert any(r.data[12:16] == (5).to_bytes(4, "big") for r in records)
        os.environ[KEY_FILE_ENV] = str(bus.directory / "key")
        try:
            limit = time.monotonic() + 5
            while time.monotonic() < limit:
                assert main(["bus", "status", "--name", config.name]) == 0
                out = capsys.readouterr().out
                if "keyed, 2 forged" in out:
                    break
                time.sleep(0.2)
            assert "keyed, 2 forged, 0 replayed and 0 malformed frames dropped" in out
        finally:
            del os.environ[KEY_FILE_ENV]
