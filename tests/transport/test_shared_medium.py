"""The shared-memory medium: address recognition, doorbells, the segment's trust, laps."""

from __future__ import annotations

import multiprocessing
import os
import select
import stat
import time

import pytest
from bus_support import bus_name

from fw1394.errors import UsageError
from fw1394.transport.media import choice as media
from fw1394.transport.media.idle import BLOCK
from fw1394.transport.media.shared_memory import RING_SIZE, SharedMedium, segment_path
from fw1394.transport.sansio.config import BusConfig

_CONTEXT = multiprocessing.get_context("fork")


def header(tag: int, kind: int, sender: int, destination: int, sequence: int = 0) -> bytes:
    # docs/virtual-bus.md, "Header": magic "FW", version 1, kind, tag, sender,
    # generation, sender's physical ID, destination, speed, reserved, sequence.
    return (
        b"FW\x01"
        + bytes([kind])
        + tag.to_bytes(4, "big")
        + sender.to_bytes(4, "big")
        + bytes(4)
        + bytes([1, destination, 2, 0])
        + sequence.to_bytes(4, "big")
    )


def test_a_member_hears_what_its_link_would_and_a_tap_everything() -> None:
    config = BusConfig(bus_name("shm-filter"), key=b"")
    member, tap, sender = SharedMedium(config), SharedMedium(config), SharedMedium(config)
    try:
        member.filter_as_member(member_id=5, phy_id=3, drop_acks=True)
        tap.filter_as_tap()
        sender.filter_as_member(member_id=6, phy_id=1, drop_acks=False)
        tag = config.tag
        frames = {
            "to 3": header(tag, 1, 6, 3),
            "to 4": header(tag, 1, 6, 4),
            "broadcast": header(tag, 1, 6, 63),
            "everyone": header(tag, 19, 6, 0xFF),
            "ack to 3": header(tag, 2, 6, 3) + bytes(8),
            "own frame": header(tag, 1, 5, 3),
            "foreign tag": header(tag ^ 1, 1, 6, 3),
            "line noise": b"\x00" * 30,
        }
        for frame in frames.values():
            sender.send(frame)
        names = {frame: name for name, frame in frames.items()}
        heard = []
        while (raw := member.receive()) is not None:
            heard.append(names[raw])
        assert heard == ["to 3", "broadcast", "everyone"]
        tapped = []
        while (stamped := tap.receive_stamped(wait=False)) is not None:
            tapped.append(names[stamped[0]])
            assert abs(stamped[1] - time.time_ns()) < 60e9  # a wall-clock stamp
        assert tapped == list(frames)[:-2]  # this bus's frames, in the order sent
        assert sender.receive_queued() is None  # its own frames never come back
    finally:
        for medium in (member, tap, sender):
            medium.close()


def test_the_segment_is_the_owners_alone() -> None:
    config = BusConfig(bus_name("shm-mode"), key=b"")
    medium = SharedMedium(config)
    try:
        mode = os.stat(segment_path(config)).st_mode
        assert stat.S_IMODE(mode) == 0o600
        assert segment_path(config).parent.name == config.name
        for directory in (segment_path(config).parent, segment_path(config).parent.parent):
            assert stat.S_IMODE(os.stat(directory).st_mode) == 0o700
    finally:
        medium.close()


def _sleeper(name: str, phy: int, pipe: multiprocessing.connection.Connection) -> None:
    medium = SharedMedium(BusConfig(name, key=b""), poll_interval=30.0, idle=BLOCK)
    medium.filter_as_member(member_id=7, phy_id=phy, drop_acks=False)
    pipe.send("ready")
    raw = medium.receive()  # one wait of up to 30 s: only the doorbell ends it sooner
    pipe.send((raw, medium.wakeups))
    medium.close()


@pytest.mark.process
def test_a_sleeper_is_woken_by_a_frame_for_it_and_only_by_that() -> None:
    config = BusConfig(bus_name("shm-bell"), key=b"")
    sender = SharedMedium(config)
    parent, child = _CONTEXT.Pipe()
    process = _CONTEXT.Process(target=_sleeper, args=(config.name, 4, child))
    process.start()
    try:
        assert parent.poll(30) and parent.recv() == "ready"
        time.sleep(0.2)  # asleep by now (a frame sent earlier is found without a bell)
        for sequence in range(100):
            sender.send(header(config.tag, 1, 6, 9, sequence))  # to someone else
        wanted = header(config.tag, 1, 6, 4, 100)
        sender.send(wanted)
        assert parent.poll(20), "the doorbell did not wake the sleeper"
        raw, wakeups = parent.recv()
        assert (raw, wakeups) == (wanted, 1)  # the 100 frames for node 9 woke nobody
    finally:
        process.join(30)
        sender.close()
    assert process.exitcode == 0


def test_a_selected_medium_is_readable_exactly_when_a_frame_waits() -> None:
    config = BusConfig(bus_name("shm-select"), key=b"")
    member, sender = SharedMedium(config), SharedMedium(config)
    try:
        member.filter_as_member(member_id=5, phy_id=2, drop_acks=False)
        sock = member.sock
        assert select.select([sock], [], [], 0.05)[0] == []
        sender.send(header(config.tag, 1, 6, 7))  # not for it: still not readable
        assert select.select([sock], [], [], 0.05)[0] == []
        frames = [header(config.tag, 1, 6, 2, n) for n in range(3)]
        for frame in frames:
            sender.send(frame)
        assert select.select([sock], [], [], 5)[0] == [sock]
        assert member.receive() == frames[0]  # one per readable event is enough too
        assert select.select([sock], [], [], 5)[0] == [sock]
        taken = []
        while (raw := member.receive_queued()) is not None:
            taken.append(raw)
        assert taken == frames[1:]
        assert select.select([sock], [], [], 0.05)[0] == []
    finally:
        member.close()
        sender.close()


def test_a_reader_lapped_by_the_writers_loses_frames_and_says_so() -> None:
    config = BusConfig(bus_name("shm-lap"), key=b"")
    slow, sender = SharedMedium(config), SharedMedium(config)
    try:
        slow.filter_as_tap()
        body = bytes(4000)
        count = 2 * RING_SIZE // len(body)
        for sequence in range(count):
            sender.send(header(config.tag, 1, 6, 3, sequence) + body)
        after = header(config.tag, 1, 6, 3, count)
        sender.send(after)
        taken = []
        while (raw := slow.receive_queued()) is not None:
            taken.append(int.from_bytes(raw[20:24], "big"))
        assert slow.overruns >= 1
        assert taken[-1] == count and len(taken) < count  # the present, not the past
        assert taken == sorted(taken)
    finally:
        slow.close()
        sender.close()


def test_udp_unless_the_environment_asks_for_shared_memory(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.delenv(media.ENVIRONMENT, raising=False)
    assert media.medium_name(BusConfig("m")) == "udp"
    assert media.medium_name(BusConfig("m", interface="10.1.2.3", ttl=1)) == "udp"
    monkeypatch.setenv(media.ENVIRONMENT, "shm")
    assert media.medium_name(BusConfig("m")) == "shm"
    opened = media.open_medium(BusConfig(bus_name("shm-env")))
    try:
        assert isinstance(opened, SharedMedium)
    finally:
        opened.close()
    with pytest.raises(UsageError, match="LAN interface"):
        media.medium_name(BusConfig("m", interface="10.1.2.3", ttl=1))
    monkeypatch.setenv(media.ENVIRONMENT, "carrier-pigeon")
    with pytest.raises(UsageError, match="FW1394_MEDIUM"):
        media.medium_name(BusConfig("m"))
