"""More bus members on a host than CPUs: an adaptive member blocks instead of polling.

The Waiter is driven over a real loopback socket whose receive calls are
recorded; the station is fed a real bus-reset frame (the wire layout of
``fw1394.transport.sansio.wire``) and must tell its medium how many members
share this host.
"""

from __future__ import annotations

import os
import socket
import struct
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import pytest

from fw1394.transport import station as station_module
from fw1394.transport.media import idle
from fw1394.transport.media.idle import Waiter, crowded
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, MemberInfo, pack_table
from fw1394.transport.station import Station


class RecordingSocket(socket.socket):
    """A UDP socket that notes the flags of every receive."""

    flags: list[int]

    def recv(self, size: int, flags: int = 0) -> bytes:
        self.flags.append(flags)
        return super().recv(size, flags)


@pytest.fixture
def receiver() -> Iterator[RecordingSocket]:
    sock = RecordingSocket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.flags = []
    sock.bind(("127.0.0.1", 0))
    # A 20 ms kernel receive timeout, as a medium sets its poll interval.
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, struct.pack("@ll", 0, 20_000))
    yield sock
    sock.close()


def test_crowded_means_more_members_than_cpus() -> None:
    assert [crowded(members, 2) for members in (1, 2, 3, 6)] == [False, False, True, True]
    assert crowded(64, 64) is False and crowded(65, 64) is True


def _wait_after_traffic(waiter: Waiter) -> bytes | None:
    waiter.traffic()  # a frame just went out: the window is open
    return waiter.receive(100)


def test_an_uncrowded_adaptive_member_polls_in_its_window(
    receiver: RecordingSocket, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(idle, "cores_enough", lambda cpus: True)  # whatever the machine's load
    waiter = Waiter(receiver, idle.IdleStrategy("adaptive", 0.01), 0.02)
    waiter.share_host(1)
    assert _wait_after_traffic(waiter) is None
    # Polls without blocking through the window, then one blocking receive.
    assert receiver.flags.count(socket.MSG_DONTWAIT) > 1
    assert receiver.flags[-1] == 0


def test_a_crowded_adaptive_member_blocks_at_once(
    receiver: RecordingSocket, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(idle, "cores_enough", lambda cpus: True)
    waiter = Waiter(receiver, idle.IdleStrategy("adaptive", 0.01), 0.02)
    waiter.share_host((os.cpu_count() or 1) + 1)
    started = time.monotonic()
    assert _wait_after_traffic(waiter) is None
    assert receiver.flags == [0]  # one blocking receive, no poll
    assert time.monotonic() - started >= 0.015  # it slept out the receive timeout
    # A frame still arrives, and uncrowded again the member polls again.
    sender = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        sender.sendto(b"answer", receiver.getsockname())
        assert waiter.receive(100) == b"answer"
    finally:
        sender.close()
    waiter.share_host(1)
    receiver.flags.clear()
    assert _wait_after_traffic(waiter) is None
    assert socket.MSG_DONTWAIT in receiver.flags


class SharingMedium:
    """A stand-in medium that keeps what the station tells it."""

    def __init__(self, config: BusConfig, poll_interval: float = 0.005, idle: object = None):
        self.shared: list[int] = []
        self.sent: list[bytes] = []
        self.deadline: Callable[[], float] | None = None

    def share_host(self, members: int) -> None:
        self.shared.append(members)

    def send(self, frame: bytes) -> None:
        self.sent.append(frame)

    def receive(self) -> bytes | None:
        return None

    def receive_queued(self) -> bytes | None:
        return None

    def sleep_until(self, deadline: Callable[[], float]) -> None:
        self.deadline = deadline

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        pass

    def close(self) -> None:
        pass


def test_a_station_tells_its_medium_how_many_members_share_its_host(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setattr(station_module, "open_medium", SharingMedium)
    config = BusConfig("crowded-station", key=b"")
    station = Station(config, rank=5)
    medium = station.medium
    assert isinstance(medium, SharingMedium)
    me = station.info
    here = [
        MemberInfo(member_id=0x100 + n, rank=n, address=me.address, pid_namespace=me.pid_namespace)
        for n in range(3)
    ]
    elsewhere = [
        MemberInfo(member_id=0x200, rank=7, address="127.0.0.2", pid_namespace=me.pid_namespace),
        MemberInfo(member_id=0x201, rank=8, address=me.address, pid_namespace=me.pid_namespace ^ 1),
    ]
    coordinator = MemberInfo(
        member_id=0x300, rank=9, contender=True, host=True, address="127.0.0.3"
    )
    table = sorted([*here, *elsewhere, me, coordinator], key=lambda m: m.sort_key)
    header = FrameHeader(FrameKind.bus_reset, config.tag, coordinator.member_id, 1, 0, 0xFF, 2, 1)
    try:
        station.take_opened(header.pack() + pack_table(tuple(table)))
        # Three members of its own host and namespace, and itself.
        assert medium.shared[-1] == 4
        told = len(medium.shared)
        station.service()  # the same generation: nothing new to tell
        assert len(medium.shared) == told
    finally:
        station.close()
