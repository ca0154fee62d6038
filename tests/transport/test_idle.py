"""Idle strategies: parsing, the environment default, and receiving on real loopback sockets."""

from __future__ import annotations

import math
import os
import socket
import struct
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from fw1394.transport.media import idle
from fw1394.transport.media.idle import (
    ADAPTIVE,
    BLOCK,
    ENVIRONMENT,
    LONGEST_SLEEP,
    SPIN,
    IdleStrategy,
    Waiter,
    cores_enough,
    default_idle,
    parse_idle,
)


def test_parse_names_and_windows() -> None:
    assert parse_idle("block") is BLOCK and BLOCK.window == 0
    assert parse_idle(" SPIN ") is SPIN and SPIN.window == math.inf
    assert parse_idle("adaptive") is ADAPTIVE
    assert parse_idle("adaptive:100") == IdleStrategy("adaptive", 100e-6)
    assert str(parse_idle("adaptive:100")) == "adaptive:100"
    assert str(ADAPTIVE) == "adaptive"
    assert parse_idle(str(parse_idle("adaptive:40"))) == parse_idle("adaptive:40")


@pytest.mark.parametrize("text", ["", "sleep", "block:10", "spin:5", "adaptive:x", "adaptive:-1"])
def test_parse_refuses_with_one_line(text: str) -> None:
    with pytest.raises(ValueError, match="idle strategy") as error:
        parse_idle(text)
    assert "\n" not in str(error.value)


def test_environment_names_the_default(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv(ENVIRONMENT, raising=False)
    assert default_idle() is ADAPTIVE
    monkeypatch.setenv(ENVIRONMENT, "block")
    assert default_idle() is BLOCK
    monkeypatch.setenv(ENVIRONMENT, "adaptive:75")
    assert default_idle().window == pytest.approx(75e-6)


def test_cores_enough_reads_the_run_queue() -> None:
    # This process is running while it looks, so no machine has enough for it
    # with no CPU at all.
    assert cores_enough(0) is False or not _has_loadavg()
    assert cores_enough(10_000) is True


def test_cores_enough_reads_the_runnable_count_afresh_at_every_look(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # /proc/loadavg's fourth field is runnable/total tasks (proc(5)).
    loadavg = tmp_path / "loadavg"
    loadavg.write_bytes(b"0.50 0.40 0.30 3/120 4242\n")
    fd = os.open(loadavg, os.O_RDONLY)
    try:
        monkeypatch.setattr(idle, "_loadavg", fd)
        assert (cores_enough(2), cores_enough(3)) == (False, True)
        loadavg.write_bytes(b"0.50 0.40 0.30 1/120 4242\n")  # same file, new count
        assert cores_enough(2) is True
    finally:
        os.close(fd)


def _has_loadavg() -> bool:
    try:
        with open("/proc/loadavg"):
            return True
    except OSError:
        return False


@pytest.fixture
def pair() -> Iterator[tuple[socket.socket, socket.socket]]:
    receiver = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    receiver.bind(("127.0.0.1", 0))
    # A 20 ms kernel receive timeout, as a medium sets its poll interval.
    receiver.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, struct.pack("@ll", 0, 20_000))
    yield receiver, sender
    receiver.close()
    sender.close()


@pytest.mark.parametrize("strategy", [BLOCK, SPIN, ADAPTIVE, parse_idle("adaptive:5000")])
def test_every_strategy_receives_and_times_out(
    pair: tuple[socket.socket, socket.socket], strategy: IdleStrategy
) -> None:
    receiver, sender = pair
    waiter = Waiter(receiver, strategy, 0.02)
    waiter.traffic()
    sender.sendto(b"frame one", receiver.getsockname())
    assert waiter.receive(100) == b"frame one"
    started = time.monotonic()
    assert waiter.receive(100) is None  # nothing comes: the poll interval ends the wait
    assert 0.005 < time.monotonic() - started < 2.0
    sender.sendto(b"frame two", receiver.getsockname())
    assert waiter.receive(100) == b"frame two"


def _receive_timeout(sock: socket.socket) -> float:
    timeval = sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, 16)
    seconds, micros = struct.unpack("@ll", timeval)
    return float(seconds + micros / 1e6)


def test_with_a_deadline_an_idle_member_sleeps_until_its_timers_are_due(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    receiver, _ = pair
    waiter = Waiter(receiver, BLOCK, 0.005)
    due = [time.monotonic() + 10.0]
    waiter.deadline = lambda: due[0]
    # The kernel keeps the timeout in scheduler ticks (4 or 10 ms): compare loosely.
    tick = 0.011
    assert waiter.receive(100) is None
    capped = _receive_timeout(receiver)
    assert capped == pytest.approx(LONGEST_SLEEP, abs=tick)  # far off: the cap
    due[0] = time.monotonic() + 0.025
    assert waiter.receive(100) is None
    sooner = _receive_timeout(receiver)
    assert sooner == pytest.approx(0.025, abs=tick) and sooner < capped  # shrinks
    due[0] = time.monotonic() - 1.0
    assert waiter.receive(100) is None
    overdue = _receive_timeout(receiver)
    assert overdue == pytest.approx(0.005, abs=tick) and overdue < sooner  # one poll interval


def test_only_data_frames_open_a_polling_window(
    pair: tuple[socket.socket, socket.socket],
) -> None:
    receiver, sender = pair
    waiter = Waiter(receiver, ADAPTIVE, 0.02, quiet_kinds=(3, 16))
    sender.sendto(bytes([0, 0, 0, 19]) + b"beacon", receiver.getsockname())
    assert waiter.receive(100) is not None
    assert waiter._last == -math.inf  # a beacon asks for no answer: no polling after it
    sender.sendto(bytes([0, 0, 0, 2]) + b"ack", receiver.getsockname())
    assert waiter.receive(100) is not None
    assert waiter._last > 0
