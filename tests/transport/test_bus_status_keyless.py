"""``bus status`` tells a keyed bus from an insecure one without the key, and lists
members only from beacons whose MAC verified.

A forger keeps sending beacons of its own (member table laid out as in
docs/virtual-bus.md, "Member table") that list a process that is not on the
bus: unsealed, and with a trailer of the right size but a made-up MAC.
"""

from __future__ import annotations

import json
import os
import struct
import threading
import time
from pathlib import Path

import pytest
from bus_support import bus_name

from fw1394.cli.main import main
from fw1394.packets.frame import FRAME_TRAILER_SIZE
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.bus_key import KEY_ENV, KEY_FILE_ENV, new_key
from fw1394.transport.supervision.launch import LaunchedBus

pytestmark = pytest.mark.process

ARGS = ("--heartbeat", "0.05", "--lease", "1.0")
FAKE_PID = 424_242


def fake_beacon(tag: int, generation: int, sealed: bool) -> bytes:
    # magic "FW", version 1, kind 19 (beacon), tag, sender, generation, sender phy,
    # destination 0xFF, speed, reserved, sequence; then table head and one entry.
    header = struct.pack(">HBBIIIBBBBI", 0x4657, 1, 19, tag, 0xBAD, generation, 0, 0xFF, 2, 0, 1)
    entry = struct.pack(">IQBBHI4s", 0xBAD, 0, 0, 7, 0, FAKE_PID, bytes([127, 0, 0, 1]))
    table = struct.pack(">IHH", 0, 1, 0) + entry
    return header + table + (bytes(FRAME_TRAILER_SIZE) if sealed else b"")


def status(name: str, capsys: pytest.CaptureFixture[str], *extra: str) -> str:
    assert main(["bus", "status", "--name", name, "--timeout", "3", *extra]) == 0
    return capsys.readouterr().out


@pytest.fixture
def no_key_here(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(KEY_ENV, raising=False)
    monkeypatch.delenv(KEY_FILE_ENV, raising=False)


@pytest.mark.usefixtures("no_key_here")
def test_status_without_the_key_says_keyed_and_lists_no_one(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    config = BusConfig(bus_name("nokey"))
    with LaunchedBus(config, 2, root=tmp_path, node_arguments=ARGS, key=new_key()) as bus:
        bus.wait_members()
        pids = [record.pid for record in bus.records()]
        stop = threading.Event()
        forger = Medium(BusConfig(config.name, key=b""))

        def forge() -> None:
            while not stop.is_set():
                for sealed in (False, True):
                    forger.send(fake_beacon(config.tag, 1, sealed))
                time.sleep(0.01)

        thread = threading.Thread(target=forge)
        thread.start()
        try:
            # Without the key: keyed, no members at all (the forged table neither).
            for _ in range(3):
                out = status(config.name, capsys)
                if "keyed (no key here)" in out:
                    break
            assert "keyed (no key here)" in out and "insecure" not in out.lower()
            assert not any(str(pid) in out for pid in [*pids, FAKE_PID])
            assert json.loads(status(config.name, capsys, "--json"))["members"] is None
            # With the key: the real members, never the forged one.
            monkeypatch.setenv(KEY_FILE_ENV, str(bus.directory / "key"))
            rows = [json.loads(line) for line in status(config.name, capsys, "--json").splitlines()]
            assert {row["security"] for row in rows} == {"keyed"}
            assert {row["pid"] for row in rows if row["role"] == "node"} == set(pids)
            assert main(["bus", "reset", "--name", config.name, "--timeout", "3"]) == 0
            capsys.readouterr()
            monkeypatch.delenv(KEY_FILE_ENV)
            # A reset asked without the key would be dropped: said at once.
            assert main(["bus", "reset", "--name", config.name, "--timeout", "3"]) == 2
            assert "keyed (no key here)" in capsys.readouterr().err
        finally:
            stop.set()
            thread.join()
            forger.close()


@pytest.mark.usefixtures("no_key_here")
def test_status_of_an_insecure_bus_says_so(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = BusConfig(bus_name("insecure-status"))
    with LaunchedBus(config, 1, root=tmp_path, node_arguments=ARGS) as bus:
        bus.wait_members()
        out = status(config.name, capsys)
        assert "insecure (INSECURE" in out and str(bus.records()[0].pid) in out
        assert os.environ.get(KEY_FILE_ENV) is None
