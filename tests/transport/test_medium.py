"""Addressed delivery: which member sockets the kernel copies a frame to."""

from __future__ import annotations

import hashlib
import math
import random
import socket

import pytest

from fw1394.transport.media.idle import ADAPTIVE
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import SHARDS, BusConfig
from fw1394.transport.sansio.wire import EVERY_MEMBER, FrameHeader, FrameKind

SO_DETACH_FILTER = 27


def _documented_groups(name: str) -> tuple[str, list[str]]:
    # docs/virtual-bus.md, "Frames": the bus group from the name's digest, then
    # the shard groups at the next SHARDS addresses, wrapping inside 1..254.
    digest = hashlib.sha256(b"fw1394-bus:" + name.encode()).digest()
    last = 1 + digest[1] % 254
    prefix = f"239.255.{digest[0]}"
    return f"{prefix}.{last}", [f"{prefix}.{1 + (last + k) % 254}" for k in range(SHARDS)]


@pytest.mark.parametrize("name", ["default", "arm", "shard-wrap-9"])
def test_groups_are_the_documented_addresses(name: str) -> None:
    config = BusConfig(name)
    group, shards = _documented_groups(name)
    assert config.group == group
    assert list(config.shard_groups) == shards
    assert len(set(shards) | {group}) == SHARDS + 1


def test_names_near_the_end_of_the_range_wrap_to_valid_addresses() -> None:
    names = (f"w{n}" for n in range(10_000))
    name = next(n for n in names if int(BusConfig(n).group.rsplit(".", 1)[1]) >= 250)
    lasts = [int(group.rsplit(".", 1)[1]) for group in BusConfig(name).shard_groups]
    assert all(1 <= last <= 254 for last in lasts)
    assert min(lasts) == 1  # wrapped past 254, never to .0 or .255


def _frame(config: BusConfig, destination: int) -> bytes:
    return FrameHeader(1, config.tag, 900, 0, 40, destination).pack()


def _unfiltered_arrivals(medium: Medium) -> list[int]:
    """Destinations of the frames the kernel queued on ``medium`` (its filter removed)."""
    heard = []
    while (raw := medium.receive()) is not None:
        heard.append(raw[17])
    return heard


def test_the_kernel_copies_an_addressed_frame_only_to_its_shard() -> None:
    config = BusConfig("shard-delivery")
    member, sender = Medium(config), Medium(config)
    try:
        member.filter_as_member(member_id=5, phy_id=1, drop_acks=False)
        # Without the link's filter the socket shows what the kernel delivers to it.
        member.sock.setsockopt(socket.SOL_SOCKET, SO_DETACH_FILTER, 0)
        same_shard = 1 + SHARDS
        for destination in (1, 2, same_shard, 63, EVERY_MEMBER):
            sender.send(_frame(config, destination))
        assert _unfiltered_arrivals(member) == [1, same_shard, 63, EVERY_MEMBER]

        # A new physical ID moves the socket to the new shard and out of the old one.
        member.filter_as_member(member_id=5, phy_id=2, drop_acks=False)
        member.sock.setsockopt(socket.SOL_SOCKET, SO_DETACH_FILTER, 0)
        for destination in (1, 2, 63):
            sender.send(_frame(config, destination))
        assert _unfiltered_arrivals(member) == [2, 63]

        # Before its first bus reset a member hears the bus-wide frames only.
        member.filter_as_member(member_id=5, phy_id=None, drop_acks=False)
        member.sock.setsockopt(socket.SOL_SOCKET, SO_DETACH_FILTER, 0)
        for destination in (2, EVERY_MEMBER):
            sender.send(_frame(config, destination))
        assert _unfiltered_arrivals(member) == [EVERY_MEMBER]
    finally:
        member.close()
        sender.close()


def test_a_tap_hears_every_destination_in_the_order_sent() -> None:
    config = BusConfig("shard-tap")
    tap, sender = Medium(config), Medium(config)
    try:
        tap.filter_as_tap()
        destinations = [*range(64), EVERY_MEMBER]
        random.Random(7).shuffle(destinations)
        for destination in destinations:
            sender.send(_frame(config, destination))
        heard = []
        while (stamped := tap.receive_stamped()) is not None:
            heard.append(stamped[0][17])
        assert heard == destinations
    finally:
        tap.close()
        sender.close()


def test_a_member_address_must_be_a_node_physical_id() -> None:
    medium = Medium(BusConfig("shard-bad-phy"))
    try:
        for phy in (-1, 63, 64, 0xFF):
            with pytest.raises(ValueError, match="not a node's"):
                medium.filter_as_member(member_id=5, phy_id=phy, drop_acks=False)
        medium.filter_as_member(member_id=5, phy_id=62, drop_acks=False)
    finally:
        medium.close()


def test_sending_bus_management_opens_no_polling_window() -> None:
    config = BusConfig("shard-quiet")
    medium = Medium(config, idle=ADAPTIVE)
    try:
        waiter = medium._waiter
        medium.send(FrameHeader(FrameKind.heartbeat, config.tag, 5, 0, 1, 0).pack())
        assert waiter._last == -math.inf
        medium.send(FrameHeader(FrameKind.async_packet, config.tag, 5, 0, 1, 2).pack())
        assert waiter._last > 0  # a request: its answer comes soon
    finally:
        medium.close()
