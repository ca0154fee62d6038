"""A node process: one board (or plain memory) on the virtual bus.

The loop is plain blocking I/O: receive a frame (the socket's receive timeout
bounds the wait), answer requests through the engine's :class:`Responder`,
and run the station's timers when they are due. A request is acked in one
frame that also carries the response when the policy concatenates them (same
bus tenure); a split response is a subaction of its own.
"""

from __future__ import annotations

import signal
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from types import FrameType

from fw1394.engine import THESIS_FPGA, Responder, ResponderPolicy
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.space import AddressSpace
from fw1394.packets.fast import encode_packet
from fw1394.transport.config import BusConfig
from fw1394.transport.faults import FaultConfig
from fw1394.transport.membership import BusReset, Refused, Timing
from fw1394.transport.station import Station
from fw1394.transport.wire import (
    ACK_PAYLOAD,
    NO_BOARD,
    FrameHeader,
    FrameKind,
    FrameTooLarge,
    ack_byte,
)

LOCAL_BUS = 0x3FF
# Plain ints: an Enum member lookup costs more than the rest of a frame's dispatch.
_ASYNC_PACKET, _ACK = int(FrameKind.async_packet), int(FrameKind.ack)
#: Wire byte of each ack code (code and parity), looked up rather than computed.
_ACK_BYTES = tuple(ack_byte(code) for code in range(16))


class BusRefusedError(RuntimeError):
    """The coordinator would not take this node (the bus already has 63)."""


@dataclass
class NodeOptions:
    config: BusConfig = field(default_factory=BusConfig)
    board_id: int = NO_BOARD
    rank: int | None = None
    timing: Timing | None = None
    faults: FaultConfig | None = None
    policy: ResponderPolicy = THESIS_FPGA
    #: Planted packet-level bugs for the fuzzer (fw1394.engine.defects); none normally.
    defects: frozenset[str] = frozenset()


class Node:
    """A station serving ``space`` through a responder."""

    def __init__(self, space: AddressSpace, options: NodeOptions) -> None:
        self.space = space
        self.options = options
        self.station = Station(
            options.config,
            rank=options.rank,
            board_id=options.board_id,
            timing=options.timing,
            faults=options.faults,
            drop_acks=True,
        )
        node_id = LOCAL_BUS << 6 | 63
        self.responder = (
            DefectiveResponder(node_id, space, options.policy, defects=options.defects)
            if options.defects
            else Responder(node_id=node_id, space=space, policy=options.policy)
        )
        self._epoch = time.monotonic()
        self._running = True
        #: Called with each bus reset this node takes part in (for logs).
        self.on_reset: Callable[[BusReset], None] | None = None
        #: Called with a line of text when the node must drop something it made.
        self.on_warning: Callable[[str], None] | None = None

    def stop(self) -> None:
        self._running = False

    def run(self) -> None:
        """Serve until :meth:`stop` (or a signal handler calling it)."""
        station = self.station
        receive, on_packet, clock = station.receive, self._on_packet, time.monotonic
        try:
            deadline = 0.0
            while self._running:
                frame = receive()
                now = clock()  # when the frame arrived: one clock reading serves the turn
                if frame is None:
                    # Bus management (or a quiet poll): the responder must learn its new
                    # physical ID before it answers the first packet of a new generation.
                    self._apply_changes()
                    deadline = min(deadline, station.next_deadline())
                elif frame[0].kind == _ASYNC_PACKET:
                    on_packet(frame[0], frame[1], now)
                if now >= deadline or now >= station.wake_by:
                    station.service(now)
                    self._apply_changes()
                    deadline = station.next_deadline()
        finally:
            station.close()

    def _apply_changes(self) -> None:
        for change in self.station.changes():
            if isinstance(change, BusReset):
                self.responder.bus_reset(LOCAL_BUS << 6 | change.phy_id, change.generation)
                if self.on_reset is not None:
                    self.on_reset(change)
            elif isinstance(change, Refused):
                raise BusRefusedError(change.reason)

    def _on_packet(self, header: FrameHeader, payload: bytes, now: float) -> None:
        station = self.station
        membership = station.membership
        if header.generation != membership.generation or membership.phy_id is None:
            return  # a packet of another generation never reaches a link after a reset
        # The responder sets the board's clock from this: ticks since the node started.
        reply = self.responder.receive(payload, now - self._epoch)
        requester = header.sender_phy
        response = b"" if reply.response is None else encode_packet(reply.response)
        if reply.ack is not None:
            tlabel = payload[2] >> 2 if len(payload) >= 3 else 0
            ack = ACK_PAYLOAD.pack(_ACK_BYTES[reply.ack], tlabel, 0, header.sequence)
            if reply.concatenated:
                try:
                    station.send(_ACK, requester, ack + response)
                    return
                except FrameTooLarge as error:
                    self._drop_response(requester, error)
                    response = b""  # the ack alone still goes out
            station.send(_ACK, requester, ack)
        if response:
            try:
                station.send(_ASYNC_PACKET, requester, response)
            except FrameTooLarge as error:
                self._drop_response(requester, error)

    def _drop_response(self, requester: int, error: FrameTooLarge) -> None:
        # The board answered (a real FPGA sends any length it is asked for) but no
        # datagram carries the answer: it is lost as on an overrun link, and the loss
        # is reported rather than silent. The requester's transaction times out.
        if self.on_warning is not None:
            self.on_warning(f"response to node {requester} dropped: {error}")


def run_node(
    space: AddressSpace,
    options: NodeOptions,
    on_reset: Callable[[BusReset], None] | None = None,
    on_warning: Callable[[str], None] | None = None,
) -> None:
    """Run a node in the foreground until SIGINT or SIGTERM; leave the bus cleanly."""
    node = Node(space, options)
    node.on_reset = on_reset
    node.on_warning = on_warning

    def stop(signum: int, frame: FrameType | None) -> None:
        node.stop()

    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        node.run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
