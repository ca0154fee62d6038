"""``fw1394 watch`` end to end: a real bus with a snake2010 node process, the real command.

The snapshot tests run ``fw1394 watch --once`` as a subprocess; the key test
runs the live view on a pseudo-terminal, presses ``e`` and ``q``, and checks
from a second host on the bus that the amplifier went on, then off on exit.
"""

from __future__ import annotations

import fcntl
import json
import os
import select
import struct
import subprocess
import sys
import termios
import time
from collections.abc import Iterator

import pytest
from bus_support import bus_name, stop, wait_until_gone

from fw1394.boards.snake2010.spec import REG_STATUS, Device, channel_register
from fw1394.host.bus_port import BusPort
from fw1394.transport.bus_host import TransactionError
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.launch import LaunchedBus

NODE_TIMING = ("--heartbeat", "0.1", "--lease", "2.0")


@pytest.fixture(scope="module")
def bus() -> Iterator[LaunchedBus]:
    config = BusConfig(bus_name("watch"))
    with LaunchedBus(config, 1, board="snake2010", node_arguments=NODE_TIMING) as launched:
        launched.wait_members()
        yield launched
    assert wait_until_gone(config.name) == []


def watch(
    *arguments: str, stdin: int | None = subprocess.DEVNULL
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", "watch", *arguments],
        capture_output=True,
        text=True,
        timeout=30,
        stdin=stdin,
    )


@pytest.mark.process
def test_snapshot_as_text(bus: LaunchedBus) -> None:
    result = watch("0", "--once", "--name", bus.config.name)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert lines[0].startswith(f"fw1394 watch  bus {bus.config.name}  ")
    assert lines[2].startswith("node 0  snake2010  board id 0  status 0x00000000  dt ")
    assert lines[3] == "  watchdog off (period 0), no timeout  enabled none  faults none  LEDs none"
    assert lines[4].split()[:4] == ["ch", "amp", "flt", "led"]
    rows = [line.split() for line in lines[5:]]
    assert [cells[0] for cells in rows] == ["1", "2", "3", "4", "5", "6", "7"]
    for cells in rows:
        assert cells[1:4] == ["off", "-", "."]
        assert cells[11] == "0x8000" and cells[-2:] == ["spd", "2.01"]


@pytest.mark.process
def test_snapshot_as_json_after_another_host_drove_the_board(bus: LaunchedBus) -> None:
    with BusPort(bus.config) as port:
        port.write_quadlet(0, REG_STATUS, 0x4040)  # enable channel 7 (mask and value)
        port.write_quadlet(0, channel_register(7, Device.DAC), 1 << 31 | 0x9000)
    try:
        result = watch("0", "--once", "--json", "--name", bus.config.name)
    finally:
        with BusPort(bus.config) as port:
            port.write_quadlet(0, channel_register(7, Device.DAC), 1 << 31 | 0x8000)
            port.write_quadlet(0, REG_STATUS, 0x4000)
    assert result.returncode == 0, result.stderr
    snapshot = json.loads(result.stdout)
    assert snapshot["bus"] == bus.config.name
    (board,) = snapshot["boards"]
    assert board["node"] == 0 and board["kind"] == "snake2010" and board["board_id"] == 0
    assert board["status"] == 0x40 and not board["watchdog_timeout"]
    channels = board["channels"]
    assert [c["channel"] for c in channels] == list(range(1, 8))
    seventh = channels[6]
    assert seventh["enabled"] and seventh["led"] and seventh["dac"] == 0x9000
    assert seventh["counts_per_second"] > 0  # its motor runs
    assert not any(c["enabled"] for c in channels[:6])


@pytest.mark.process
def test_errors_are_one_line(bus: LaunchedBus) -> None:
    missing = watch("5", "--once", "--name", bus.config.name)
    assert missing.returncode == 2
    assert missing.stderr == (
        f"fw1394: error: no node 5 on bus '{bus.config.name}' (nodes: 0; is it up? "
        f"fw1394 bus up --name {bus.config.name} --board snake2010 --nodes N)\n"
    )
    no_terminal = watch("0", "--name", bus.config.name)
    assert no_terminal.returncode == 2
    assert no_terminal.stderr == (
        "fw1394: error: the live view needs a terminal; use --once for a snapshot\n"
    )
    assert watch("0", "--json").stderr.startswith("fw1394: error: --json goes with --once")


@pytest.mark.process
def test_no_such_bus() -> None:
    result = watch(
        "0", "--once", "--name", bus_name("absent"), "--lease", "0.5", "--heartbeat", "0.1"
    )
    assert result.returncode == 2
    assert result.stderr.startswith("fw1394: error: bus ") and "has no nodes" in result.stderr


class Terminal:
    """``fw1394 watch`` on a pseudo-terminal of 40 x 140 characters."""

    def __init__(self, *arguments: str) -> None:
        controller, terminal = os.openpty()
        fcntl.ioctl(terminal, termios.TIOCSWINSZ, struct.pack("HHHH", 40, 140, 0, 0))
        self.fd = controller
        self.output = bytearray()
        self.process = subprocess.Popen(
            [sys.executable, "-m", "fw1394.cli.main", "watch", *arguments],
            stdin=terminal,
            stdout=terminal,
            stderr=terminal,
            env={**os.environ, "TERM": "xterm"},
            start_new_session=True,
        )
        os.close(terminal)

    def read(self, seconds: float) -> None:
        limit = time.monotonic() + seconds
        while time.monotonic() < limit:
            ready, _, _ = select.select([self.fd], [], [], 0.02)
            if ready:
                try:
                    self.output.extend(os.read(self.fd, 65536))
                except OSError:  # the other side closed: the process ended
                    return

    def wait_for(self, text: bytes, seconds: float = 10.0) -> None:
        limit = time.monotonic() + seconds
        while text not in self.output:
            assert time.monotonic() < limit, f"{text!r} never shown: {bytes(self.output)!r}"
            self.read(0.05)

    def close(self) -> None:
        stop(self.process)  # SIGTERM: the view leaves as after "q"
        os.close(self.fd)


def enables(port: BusPort) -> int:
    """Enable bits of node 0, retried over a bus reset (a host joining or leaving)."""
    for _ in range(5):
        try:
            return port.read_quadlet(0, REG_STATUS) & 0xFF
        except TransactionError:
            time.sleep(0.05)
    raise AssertionError("node 0 does not answer")


def settle(view: Terminal, observer: BusPort, seconds: float) -> None:
    """Let the view run while the observer keeps answering the bus (heartbeats, self-IDs)."""
    limit = time.monotonic() + seconds
    while time.monotonic() < limit:
        view.read(0.05)
        observer.poll(0.02)


@pytest.mark.process
def test_live_view_enables_and_switches_off_on_quit(bus: LaunchedBus) -> None:
    view = Terminal("0", "--name", bus.config.name)
    try:
        view.wait_for(b"keys:")
        # The observer joins once the view is up; the view rides out that bus reset
        # (one refresh may fail) before the first key.
        with BusPort(bus.config, timing=Timing(heartbeat=0.1, lease=2.0)) as observer:
            assert enables(observer) == 0
            settle(view, observer, 0.5)
            os.write(view.fd, b"e")
            limit = time.monotonic() + 5
            while enables(observer) != 0b1 and time.monotonic() < limit:
                settle(view, observer, 0.05)
            assert enables(observer) == 0b1
            view.wait_for(b"amplifier on")
            os.write(view.fd, b"q")
            view.process.wait(10)
            view.read(0.2)
            assert view.process.returncode == 0, bytes(view.output)
            assert b"fw1394 watch: node 0: amplifier 1 off" in view.output
            assert enables(observer) == 0
    finally:
        view.close()
