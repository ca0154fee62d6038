"""A node process's loop serves requests by the one-pass turn, and leaves cleanly."""

from __future__ import annotations

from collections import deque
from collections.abc import Callable
from pathlib import Path

import pytest

from fw1394.boards.memory.board import MemorySpace
from fw1394.node.process import Node, NodeOptions
from fw1394.packets import QuadletReadRequest, QuadletReadResponse
from fw1394.packets.fast import encode_packet
from fw1394.transport import station as station_module
from fw1394.transport.media.idle import BLOCK, IdleStrategy
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import HEADER_SIZE, FrameHeader, FrameKind, MemberInfo, pack_table

HOST = MemberInfo(member_id=0x0505, rank=9, contender=True, host=True)


class ScriptedMedium:
    """Hands out ``inbox``, then calls ``when_empty`` (and is quiet)."""

    def __init__(self, config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK):
        self.inbox: deque[bytes] = deque()
        self.sent: list[bytes] = []
        self.when_empty: Callable[[], None] = lambda: None
        self.deadline: Callable[[], float] | None = None

    def receive(self) -> bytes | None:
        if self.inbox:
            return self.inbox.popleft()
        self.when_empty()
        return None

    def receive_queued(self) -> bytes | None:
        return None

    def send(self, frame: bytes) -> None:
        self.sent.append(frame)

    def sleep_until(self, deadline: Callable[[], float]) -> None:
        self.deadline = deadline

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None:
        pass

    def close(self) -> None:
        pass


def test_the_node_loop_answers_a_read_without_the_general_turn(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path))
    monkeypatch.setattr(station_module, "open_medium", ScriptedMedium)
    config = BusConfig("node-loop", key=b"")
    node = Node(MemorySpace(64, contents=bytes(range(64))), NodeOptions(config, rank=1))
    medium = node.station.medium
    assert isinstance(medium, ScriptedMedium)
    # Idle, the node sleeps until its membership's timers are due, not a poll interval.
    assert medium.deadline is not None and medium.deadline() == node.station.next_deadline()
    medium.when_empty = node.stop
    reset = pack_table((HOST, node.station.info))
    request = QuadletReadRequest(destination_id=0xFFC1, tlabel=7, source_id=0xFFC0, offset=8)
    for kind, payload, sequence in (
        (FrameKind.bus_reset, reset, 1),
        (FrameKind.async_packet, encode_packet(request), 2),
    ):
        header = FrameHeader(kind, config.tag, HOST.member_id, 1, 0, 0xFF, 2, sequence)
        medium.inbox.append(header.pack() + payload)
    general: list[object] = []  # frames the general turn served
    settle = node.link.settle

    def counted(frame: tuple[FrameHeader, bytes] | None, now: float) -> None:
        general.append(frame)
        settle(frame, now)

    node.link.settle = counted  # type: ignore[method-assign]
    node.run()
    answers = [frame for frame in medium.sent if frame[3] == FrameKind.ack]
    assert len(answers) == 1
    expected = QuadletReadResponse(
        destination_id=0xFFC0, tlabel=7, source_id=0xFFC1, quadlet_data=0x08090A0B
    )
    assert answers[0][HEADER_SIZE + 8 :] == encode_packet(expected)
    # The reset and the quiet poll at the end went the general way; the request not.
    assert len(general) == 2 and general[1] is None
    assert medium.sent[-1][3] == FrameKind.leave  # closed: the node left the bus
