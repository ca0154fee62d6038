"""The shared-memory medium on a crowded bus: an adaptive member blocks at once.

Polling on the ring is a loop of looks with ``sched_yield`` between them; the
test counts the yields. Frames are written from the layout in
``docs/virtual-bus.md`` ("Header").
"""

from __future__ import annotations

import os

import pytest
from bus_support import bus_name

from fw1394.transport.media import idle
from fw1394.transport.media.idle import IdleStrategy
from fw1394.transport.media.shared_memory import SharedMedium
from fw1394.transport.sansio.config import BusConfig

WINDOW = IdleStrategy("adaptive", 0.02)


def _data_frame(tag: int, sender: int, destination: int) -> bytes:
    # magic "FW", version 1, kind 1 (an async packet), tag, sender, generation,
    # sender's physical ID, destination, speed, reserved, sequence.
    return (
        b"FW\x01\x01"
        + tag.to_bytes(4, "big")
        + sender.to_bytes(4, "big")
        + bytes(4)
        + bytes([1, destination, 2, 0])
        + bytes(4)
    )


@pytest.mark.parametrize("crowded", [False, True])
def test_an_adaptive_member_polls_only_on_an_uncrowded_bus(
    crowded: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    yields: list[None] = []
    monkeypatch.setattr(os, "sched_yield", lambda: yields.append(None))
    monkeypatch.setattr(idle, "cores_enough", lambda cpus: True)  # whatever the load
    config = BusConfig(bus_name("shm-crowded"), key=b"")
    member, sender = SharedMedium(config, 0.01, WINDOW), SharedMedium(config)
    try:
        member.filter_as_member(member_id=5, phy_id=3, drop_acks=True)
        sender.filter_as_member(member_id=6, phy_id=1, drop_acks=False)
        member.share_host((os.cpu_count() or 1) + 1 if crowded else 1)
        member.send(_data_frame(config.tag, 5, 1))  # traffic: the window opens
        assert member.receive() is None  # nothing comes: poll (or not), then block
        assert (len(yields) > 0) is not crowded
        sender.send(_data_frame(config.tag, 6, 3))
        assert member.receive() == _data_frame(config.tag, 6, 3)  # still heard
    finally:
        member.close()
        sender.close()
