"""The frame floor: a read's own three frames, exchanged with a responder process."""

from __future__ import annotations

import os
import statistics

import pytest

from fw1394.engine.requester import concatenated_data
from fw1394.experiments.frame_floor import FRAMES, HOST, NODE, FrameFloor, frames
from fw1394.packets import AckCode, QuadletReadRequest, QuadletReadResponse, decode
from fw1394.packets.ack import ACK_BYTES
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import HEADER_SIZE, FrameKind, parse_ack, parse_header


def test_the_frames_are_a_quadlet_read_that_the_host_would_accept() -> None:
    config = BusConfig("floor-bytes")
    request, answer, ack = frames(config)
    assert FRAMES == 3
    host_id, node_id = 0xFFC0 | HOST[1], 0xFFC0 | NODE[1]
    # The request: a quadlet read from the host's node ID to the node's.
    head = parse_header(request)
    assert (head.kind, head.sender_phy, head.destination, head.tag) == (
        FrameKind.async_packet, HOST[1], NODE[1], config.tag,
    )  # fmt: skip
    read = decode(request[HEADER_SIZE:])
    assert isinstance(read, QuadletReadRequest)
    assert (read.destination_id, read.source_id, read.tlabel) == (node_id, host_id, 1)
    # The answer: ack_pending with the response behind it, which the host's one-pass
    # path takes as this read's data.
    head = parse_header(answer)
    assert (head.kind, head.sender_phy, head.destination) == (FrameKind.ack, NODE[1], HOST[1])
    pending = parse_ack(answer[HEADER_SIZE:])
    assert pending.ack_byte == ACK_BYTES[AckCode.ack_pending] and pending.tlabel == 1
    assert isinstance(decode(pending.concatenated), QuadletReadResponse)
    data = concatenated_data(
        answer[HEADER_SIZE:], NODE[1], QuadletReadResponse, node_id, -1, host_id
    )
    assert data is not None and len(data) == 4
    # The requester's ack of the response.
    head = parse_header(ack)
    assert (head.kind, head.sender_phy, head.destination) == (FrameKind.ack, HOST[1], NODE[1])
    complete = parse_ack(ack[HEADER_SIZE:])
    assert complete.ack_byte == ACK_BYTES[AckCode.ack_complete] and not complete.concatenated


@pytest.mark.process
def test_a_round_times_every_exchange_and_close_stops_the_responder() -> None:
    floor = FrameFloor()
    try:
        samples, failures = floor.round(300, warmup=20)
        pid = floor.pid
    finally:
        floor.close()
    assert len(samples) == 300 and failures == 0
    assert 0 < min(samples) <= statistics.median(samples) < 10_000
    assert not os.path.exists(f"/proc/{pid}")
