"""A node process: one board (or plain memory) on the virtual bus.

The loop is plain blocking I/O: receive a frame (the socket's receive timeout
bounds the wait), answer requests through the link layer (:class:`ResponderLink`),
and run the station's timers when they are due. A common request takes that turn
in one pass (:func:`~fw1394.transport.node_express.node_turn`, the responder's
:meth:`~fw1394.engine.Responder.serve`). A request is acked in one
frame that also carries the response when the policy concatenates them (same
bus tenure); a split response is a subaction of its own.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field

from fw1394.engine import THESIS_FPGA, Responder, ResponderPolicy
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.faults import FaultConfig
from fw1394.engine.space import AddressSpace
from fw1394.packets.nodeid import BROADCAST_ID
from fw1394.transport.link import BusRefusedError, ResponderLink
from fw1394.transport.media.idle import IdleStrategy
from fw1394.transport.node_express import node_turn
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import BusReset, Timing
from fw1394.transport.sansio.wire import NO_BOARD, FrameTooLarge
from fw1394.transport.station import Station
from fw1394.transport.supervision.procs import run_until_signalled

__all__ = ["BusRefusedError", "Node", "NodeOptions", "run_node"]


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
    #: How the node waits for requests; None: ``FW1394_IDLE``, else adaptive.
    idle: IdleStrategy | None = None


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
            idle=options.idle,
        )
        # Idle, the node sleeps until its membership's next timer: a node has no
        # transaction of its own to time out.
        self.station.medium.sleep_until(self.station.next_deadline)
        # No physical ID before the first self-ID phase: the link's reset hook gives it.
        self.responder = (
            DefectiveResponder(BROADCAST_ID, space, options.policy, defects=options.defects)
            if options.defects
            else Responder(node_id=BROADCAST_ID, space=space, policy=options.policy)
        )
        self.link = ResponderLink(
            self.responder,
            self.station.send,
            self.station,
            epoch=time.monotonic(),
            on_drop=self._drop_response,
        )
        self._running = True
        #: Called with a line of text when the node must drop something it made.
        self.on_warning: Callable[[str], None] | None = None

    @property
    def on_reset(self) -> Callable[[BusReset], None] | None:
        """Called with each bus reset this node takes part in (for logs)."""
        return self.link.on_reset

    @on_reset.setter
    def on_reset(self, hook: Callable[[BusReset], None] | None) -> None:
        self.link.on_reset = hook

    def stop(self) -> None:
        self._running = False

    def run(self) -> None:
        """Serve until :meth:`stop` (or a signal handler calling it)."""
        turn = node_turn(self.link)
        try:
            while self._running:
                turn()
        finally:
            self.station.close()

    def _drop_response(self, requester: int, error: FrameTooLarge) -> None:
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

    run_until_signalled(node.run, node.stop)
