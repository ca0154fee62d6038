"""The tunnel's pieces on their own: names, frames, the kernel filter, faults, fast codec."""

from __future__ import annotations

import socket

import pytest

from fw1394.engine.faults import FaultConfig, FaultInjector
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import BusConfig, BusNameError
from fw1394.transport.sansio.wire import (
    AckPayload,
    FrameHeader,
    FrameKind,
    MemberInfo,
    ack_byte,
    pack_join,
    pack_table,
    parse_ack,
    parse_header,
    parse_join,
    parse_table,
)


def test_names_give_distinct_groups_ports_and_tags() -> None:
    a, b = BusConfig("arm"), BusConfig("leg")
    assert (a.group, a.port, a.tag) == (BusConfig("arm").group, BusConfig("arm").port, a.tag)
    assert a.tag != b.tag and (a.group, a.port) != (b.group, b.port)
    assert a.group.startswith("239.255.") and 20000 <= a.port < 30000
    for bad in ("", "with space", "x" * 64, "../up", "-dash"):
        with pytest.raises(BusNameError):
            BusConfig(bad)


def test_frame_header_and_payloads_round_trip() -> None:
    header = FrameHeader(FrameKind.ack, 0xDEADBEEF, 7, 12, 3, 63, 2, 0xFFFFFFFF)
    raw = header.pack() + AckPayload(ack_byte(2), 17, 99, b"resp").pack()
    assert parse_header(raw) == header
    ack = parse_ack(raw[24:])
    assert (ack.code, ack.tlabel, ack.acked_sequence, ack.concatenated) == (2, 17, 99, b"resp")
    assert ack_byte(1) == 0x1E  # ack_complete with its parity nibble
    members = (
        MemberInfo(1, 0, board_id=3, pid=10, address="10.0.0.2", pid_namespace=5),
        MemberInfo(2, 9, contender=True, host=True),
    )
    assert parse_table(pack_table(members, initiator=2)) == (2, members)
    assert parse_join(pack_join(members[0], 2)) == (members[0], 2)


def test_the_kernel_filter_passes_what_a_link_would() -> None:
    config = BusConfig("filtertest")
    member, tap, sender = Medium(config), Medium(config), Medium(config)
    other_bus = Medium(BusConfig("filtertest-other"))
    try:
        member.filter_as_member(member_id=5, phy_id=3, drop_acks=True)
        tap.filter_as_tap()
        sender.filter_as_member(member_id=6, phy_id=1, drop_acks=False)
        other_bus.filter_as_tap()
        frames = {
            "to 3": FrameHeader(1, config.tag, 6, 0, 1, 3).pack(),
            "to 4": FrameHeader(1, config.tag, 6, 0, 1, 4).pack(),
            "broadcast": FrameHeader(1, config.tag, 6, 0, 1, 63).pack(),
            "everyone": FrameHeader(19, config.tag, 6, 0, 1, 0xFF).pack(),
            "ack to 3": FrameHeader(2, config.tag, 6, 0, 1, 3).pack() + bytes(8),
            "own frame": FrameHeader(1, config.tag, 5, 0, 3, 3).pack(),
            "foreign tag": FrameHeader(1, config.tag ^ 1, 6, 0, 1, 3).pack(),
        }
        for frame in frames.values():
            sender.send(frame)
        names = {frame: name for name, frame in frames.items()}
        heard = []
        while (raw := member.receive()) is not None:
            heard.append(names[raw])
        assert heard == ["to 3", "broadcast", "everyone"]
        seen = 0
        while tap.receive_stamped() is not None:
            seen += 1
        assert seen == len(frames) - 1  # everything with this bus's tag
        assert other_bus.receive() is None
    finally:
        for medium in (member, tap, sender, other_bus):
            medium.close()


def test_default_sockets_stay_on_loopback() -> None:
    medium = Medium(BusConfig("looptest"))
    try:
        sock = medium.sock
        interface = sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_IF, 4)
        assert socket.inet_ntoa(interface) == "127.0.0.1"
        assert sock.getsockopt(socket.IPPROTO_IP, socket.IP_MULTICAST_TTL) == 0
    finally:
        medium.close()


def test_faults() -> None:
    assert FaultInjector(FaultConfig(loss=1.0)).send_times(1.0) == []
    assert FaultInjector(FaultConfig(duplicate=1.0)).send_times(1.0) == [1.0, 1.0]
    assert FaultInjector(FaultConfig(delay=1.0, delay_seconds=0.5)).send_times(1.0) == [1.5]
    dice = FaultInjector(FaultConfig(loss=0.05, seed=3))
    lost = sum(not dice.send_times(0.0) for _ in range(10000))
    assert 350 < lost < 650 and dice.lost == lost
    with pytest.raises(ValueError, match="probability"):
        FaultConfig(loss=1.5)
