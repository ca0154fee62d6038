"""A frame the medium duplicates is one datagram twice: a keyed bus drops the copy."""

from __future__ import annotations

import os

from fw1394.engine.faults import FaultConfig
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.seal import Verifier
from fw1394.transport.sansio.wire import FrameKind
from fw1394.transport.station import Station


def test_a_duplicated_frame_is_dropped_as_a_replay_on_a_keyed_bus() -> None:
    key = os.urandom(32)
    config = BusConfig(f"dupcopy-{os.getpid()}", key=key)
    station = Station(config, faults=FaultConfig(duplicate=1.0, seed=1))
    sent: list[bytes] = []
    station.medium.send = sent.append  # type: ignore[method-assign, assignment]
    try:
        for _ in range(3):
            station.send(int(FrameKind.async_packet), 0, bytes(16))
    finally:
        station.close()
    assert len(sent) == 6  # every frame went out twice
    assert all(sent[i] == sent[i + 1] for i in range(0, 6, 2))  # as the same datagram
    verifier = Verifier(key)
    opened = [verifier.open(frame) is not None for frame in sent]
    assert opened == [True, False] * 3  # each first copy taken, each second one a replay
    assert verifier.dropped.replayed == 3 and verifier.dropped.forged == 0
