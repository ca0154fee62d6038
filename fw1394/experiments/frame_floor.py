"""The floor under a quadlet read on the virtual bus: its three frames, with no work done.

A read is three frames: the request, the node's ack with the response
concatenated, and the requester's ack of that response. :class:`FrameFloor`
sends those very bytes (from the codec) between the bench and a responder
process, two filtered members of a bus of their own, and does nothing else:
no engine, no board, no checks. That is the least any quadlet read on this
transport can cost with Python at both ends. Timed in the same interleaved
rounds as the raw ping-pong and the reads, its ratio to raw says how much of
the read's ratio the transport itself takes, and the read's time above it is
what the stacks of both ends add.

``python -m fw1394.experiments.frame_floor BUS PARENT_PID`` is the responder.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time

from fw1394.experiments.baseline import stop_process
from fw1394.experiments.timing import TargetError, pin, time_calls
from fw1394.packets import AckCode, QuadletReadRequest, QuadletReadResponse
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import node_id
from fw1394.transport.media.idle import default_idle
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import AckPayload, FrameHeader, FrameKind, ack_byte
from fw1394.transport.supervision.procs import die_with_parent

#: The two ends' member IDs and physical IDs on their own bus.
HOST, NODE = (101, 1), (102, 2)
#: A quadlet read's frames on the wire, in order.
FRAMES = 3
#: How long either end waits for a frame before it counts as lost.
WAIT_S = 1.0


def frames(config: BusConfig) -> tuple[bytes, bytes, bytes]:
    """The request, the ack with the response, and the requester's ack: a read's bytes."""
    (host, host_phy), (node, node_phy) = HOST, NODE
    host_id, node = node_id(host_phy), node_id(node_phy)
    read = QuadletReadRequest(destination_id=node, tlabel=1, source_id=host_id)
    response = QuadletReadResponse(destination_id=host_id, tlabel=1, source_id=node)
    pending = AckPayload(ack_byte(AckCode.ack_pending), 1, 1, encode_packet(response))
    complete = AckPayload(ack_byte(AckCode.ack_complete), 1, 1)
    tag = config.tag
    request = FrameHeader(FrameKind.async_packet, tag, host, 0, host_phy, node_phy).pack()
    answer = FrameHeader(FrameKind.ack, tag, node, 0, node_phy, host_phy).pack()
    ack = FrameHeader(FrameKind.ack, tag, host, 0, host_phy, node_phy).pack()
    return request + encode_packet(read), answer + pending.pack(), ack + complete.pack()


class FrameFloor:
    """The bench's end and a responder process, kept for a whole run (rounds interleave)."""

    def __init__(self, cpus: set[int] | None = None) -> None:
        self.config = BusConfig(f"floor{os.getpid()}-{time.monotonic_ns() % 100_000}")
        self.request, _, self.ack = frames(self.config)
        # The bench's end filters as a host does (acks reach it); it waits as members do.
        self.medium = Medium(self.config, WAIT_S, default_idle())
        try:
            self.medium.filter_as_member(HOST[0], HOST[1], False)
            self.responder = subprocess.Popen(
                [sys.executable, "-m", __name__, self.config.name, str(os.getpid())],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                text=True,
            )
        except BaseException:
            self.medium.close()
            raise
        try:
            assert self.responder.stdout is not None
            if self.responder.stdout.readline().strip() != "ready":
                raise RuntimeError("the frame-floor responder did not start")
            if cpus is not None:
                pin([self.responder.pid], cpus)
        except BaseException:
            self.close()
            raise

    @property
    def pid(self) -> int:
        return self.responder.pid

    def exchange(self) -> None:
        """The three frames, once; TargetError if no answer comes."""
        medium = self.medium
        medium.send(self.request)
        if medium.receive() is None:
            raise TargetError("the frame-floor responder did not answer within 1 s")
        medium.send(self.ack)

    def round(self, count: int, *, warmup: int = 0) -> tuple[list[float], int]:
        """``count`` timings of the three frames in µs, and how many attempts failed."""
        return time_calls(self.exchange, count, warmup=warmup)

    def close(self) -> None:
        try:
            stop_process(self.responder)
        finally:
            self.medium.close()


def serve(bus: str, parent: int) -> None:
    """The responder: answer every request with the ack and response, until the parent dies."""
    die_with_parent(parent)
    config = BusConfig(bus)
    _, answer, _ = frames(config)
    medium = Medium(config, WAIT_S, default_idle())
    # A node's filter: acks never wake it, as they never wake a node.
    medium.filter_as_member(NODE[0], NODE[1], True)
    print("ready", flush=True)
    receive, send = medium.receive, medium.send
    while True:
        if receive() is not None:
            send(answer)


if __name__ == "__main__":  # pragma: no cover - runs as the responder process
    serve(sys.argv[1], int(sys.argv[2]))
