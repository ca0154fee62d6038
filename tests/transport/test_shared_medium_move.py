"""A writer stopped while it holds the ring's lock cannot wedge a shared-memory bus.

The survivors move the bus to a fresh segment; the stopped writer, resumed,
finishes its record in the retired ring, where nobody reads it, and follows.
Frames are built from the header table of ``docs/virtual-bus.md``.
"""

from __future__ import annotations

import multiprocessing
import multiprocessing.connection
import os
import select
import signal

import pytest
from bus_support import bus_name
from polling import wait_until

from fw1394.transport.media.idle import BLOCK
from fw1394.transport.media.shared_memory import (
    _ARMED_AT,
    _SLOTS_AT,
    RING_SIZE,
    SharedMedium,
    segment_path,
)
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.procs import process_stopped

pytestmark = pytest.mark.process

_CONTEXT = multiprocessing.get_context("fork")


def frame(tag: int, sender: int, sequence: int) -> bytes:
    # magic "FW", version 1, kind 1 (async packet), tag, sender, generation 0,
    # sender's physical ID, destination 63 (broadcast), speed, reserved, sequence.
    return (
        b"FW\x01\x01"
        + tag.to_bytes(4, "big")
        + sender.to_bytes(4, "big")
        + bytes(4)
        + bytes([1, 63, 2, 0])
        + sequence.to_bytes(4, "big")
        + b"payload"
    )


def _stale_writer(name: str, pipe: multiprocessing.connection.Connection) -> None:
    config = BusConfig(name, key=b"")
    medium = SharedMedium(config)
    medium.filter_as_member(member_id=9, phy_id=2, drop_acks=False)
    medium.send(frame(config.tag, 9, 1))
    medium._lock()
    pipe.send("holding")
    os.kill(os.getpid(), signal.SIGSTOP)
    # Resumed: finish "the" record it was writing when it stopped, as a writer
    # would, at the head it read before; then let go.
    head = medium.head
    stale = frame(config.tag, 9, 2)
    medium._write_record(head, head % RING_SIZE, stale, len(stale))
    medium._unlock()
    medium.send(frame(config.tag, 9, 3))  # its next frame goes to the bus it finds
    pipe.send(medium.moves)
    medium.close()


def heard(tap: SharedMedium, count: int) -> list[bytes]:
    frames: list[bytes] = []

    def more() -> bool:
        while (raw := tap.receive_queued()) is not None:
            frames.append(raw)
        return len(frames) >= count

    wait_until(more, timeout=30)
    return frames


def test_a_stopped_lock_holder_is_left_behind_and_cannot_write_into_the_new_bus() -> None:
    config = BusConfig(bus_name("shm-move"), key=b"")
    tap, late, writer = SharedMedium(config), SharedMedium(config), SharedMedium(config)
    tap.filter_as_tap()
    late.filter_as_tap()  # reads only at the end: from the retired ring first
    writer.filter_as_member(member_id=5, phy_id=1, drop_acks=False)
    selected = tap.sock  # a select()ing reader keeps its socket across the move
    before = os.stat(segment_path(config)).st_ino
    parent, child = _CONTEXT.Pipe()
    process = _CONTEXT.Process(target=_stale_writer, args=(config.name, child))
    process.start()
    pid = process.pid
    assert pid is not None
    try:
        assert parent.poll(30) and parent.recv() == "holding"
        wait_until(lambda: process_stopped(pid), timeout=30)
        writer.send(frame(config.tag, 5, 10))  # returns: the bus moved on without the holder
        assert os.stat(segment_path(config)).st_ino != before
        assert [f[-11:] for f in heard(tap, 2)] == [
            (1).to_bytes(4, "big") + b"payload",
            (10).to_bytes(4, "big") + b"payload",
        ]
        writer.send(frame(config.tag, 5, 11))
        assert select.select([selected], [], [], 30)[0] == [selected]
        assert heard(tap, 1) == [frame(config.tag, 5, 11)]
        os.kill(pid, signal.SIGCONT)
        assert parent.poll(30) and parent.recv() == 1  # it followed, once
        # Its stale record (sequence 2) stayed in the retired ring; sequence 3 came here.
        assert heard(tap, 1) == [frame(config.tag, 9, 3)]
        assert (tap.moves, writer.moves) == (1, 1)
        writer.send(frame(config.tag, 5, 12))
        assert heard(tap, 1) == [frame(config.tag, 5, 12)]
        # The late reader reads the retired ring up to the move, never the stale
        # record after it, then the new ring: one bus order for every reader.
        assert heard(late, 5) == [
            frame(config.tag, 9, 1),
            frame(config.tag, 5, 10),
            frame(config.tag, 5, 11),
            frame(config.tag, 9, 3),
            frame(config.tag, 5, 12),
        ]
        assert late.moves == 1
    finally:
        os.kill(pid, signal.SIGCONT)
        process.join(30)
        for medium in (tap, late, writer):
            medium.close()
    assert process.exitcode == 0


def _sleeper(name: str, pipe: multiprocessing.connection.Connection) -> None:
    medium = SharedMedium(BusConfig(name, key=b""), poll_interval=30.0, idle=BLOCK)
    medium.filter_as_member(member_id=7, phy_id=3, drop_acks=False)
    pipe.send("ready")
    raw = medium.receive()  # one wait of up to 30 s: only a ring ends it sooner
    pipe.send((raw, medium.moves, medium.wakeups))
    medium.close()


def _holder(name: str, pipe: multiprocessing.connection.Connection) -> None:
    medium = SharedMedium(BusConfig(name, key=b""))
    medium._lock()
    pipe.send("holding")
    os.kill(os.getpid(), signal.SIGSTOP)
    medium._unlock()
    medium.close()


def test_a_member_asleep_in_receive_is_rung_when_the_bus_moves_and_follows_it() -> None:
    config = BusConfig(bus_name("shm-move-sleep"), key=b"")
    writer = SharedMedium(config)
    writer.filter_as_member(member_id=5, phy_id=1, drop_acks=False)
    asleep, sleeper_end = _CONTEXT.Pipe()
    sleeper = _CONTEXT.Process(target=_sleeper, args=(config.name, sleeper_end))
    holding, holder_end = _CONTEXT.Pipe()
    holder = _CONTEXT.Process(target=_holder, args=(config.name, holder_end))
    sleeper.start()
    try:
        assert asleep.poll(30) and asleep.recv() == "ready"
        # Armed (about to sleep, or asleep) before the holder takes the lock: armed
        # later, it would find the holder stopped itself and move the bus unrung.
        wait_until(lambda: any(writer._mm[_ARMED_AT:_SLOTS_AT]), timeout=30)
        holder.start()
        pid = holder.pid
        assert pid is not None
        assert holding.poll(30) and holding.recv() == "holding"
        wait_until(lambda: process_stopped(pid), timeout=30)
        # The sleeper waits on the old segment's doorbell; the frame goes on the new
        # one: only the move's ring of every sleeper sends it there in time.
        writer.send(frame(config.tag, 5, 10))
        assert asleep.poll(20), "the sleeper was not rung when the bus moved"
        raw, moves, wakeups = asleep.recv()
        assert (raw, moves) == (frame(config.tag, 5, 10), 1)
        assert wakeups in (1, 2)  # the move's ring, and maybe the frame's in the new ring
    finally:
        if holder.pid is not None:
            os.kill(holder.pid, signal.SIGCONT)
            holder.join(30)
        sleeper.join(30)
        writer.close()
    assert (holder.exitcode, sleeper.exitcode) == (0, 0)
