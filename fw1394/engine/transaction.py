"""One outstanding transaction of a requester, and how a response is judged against it."""

from __future__ import annotations

import math

from fw1394.engine.events import Event, LockCompleted, ReadCompleted, WriteCompleted
from fw1394.engine.table import RESPONSE_TCODES
from fw1394.packets import (
    ASYNC_CLASSES,
    AsyncPacket,
    BlockReadResponse,
    LockRequest,
    LockResponse,
    QuadletReadResponse,
    RCode,
    Request,
    Response,
    TCode,
)
from fw1394.packets.nodeid import LOCAL_BUS, bus_of, phy_of

#: Where a transaction stands; QUEUED: not sent yet, waiting for a free label.
AWAIT_ACK, AWAIT_RESPONSE, BUSY_WAIT, QUEUED = 0, 1, 2, 3
_RESPONSE_CLASS: dict[int, type[AsyncPacket]] = {
    request: ASYNC_CLASSES[TCode(response)] for request, response in RESPONSE_TCODES.items()
}


def same_node(a: int, b: int) -> bool:
    """Whether two node IDs name the same node; bus LOCAL_BUS (0x3FF) means "the local bus"."""
    return a == b or (phy_of(a) == phy_of(b) and (bus_of(a) == LOCAL_BUS or bus_of(b) == LOCAL_BUS))


class Transaction:
    """A started transaction the requester still owes an event for."""

    __slots__ = (
        "busy",
        "deadline",
        "destination_id",
        "expects_response",
        "key",
        "label",
        "length",
        "queued",
        "request",
        "response_class",
        "state",
        "tid",
    )

    def __init__(
        self, tid: int, key: int, label: int, request: Request, length: int, expects: bool
    ) -> None:
        self.tid = tid
        #: The destination's physical ID, which owns the label.
        self.key = key
        #: -1 while the transaction waits for a free label.
        self.label = label
        self.destination_id = request.destination_id
        #: The packet as last sent (a busy retry changes its retry code).
        self.request = request
        #: Expected length of the response's data; -1: not checked.
        self.length = length
        self.response_class = _RESPONSE_CLASS[request.LAYOUT.tcode]
        #: Reads and locks need a response packet; a write may end with its ack.
        self.expects_response = expects
        self.state = AWAIT_ACK if label >= 0 else QUEUED
        #: When the current state times out.
        self.deadline = 0.0
        #: When this transaction's live timer entry is due (never after ``deadline``);
        #: infinity while it has none.
        self.queued = math.inf
        #: Busy retries so far.
        self.busy = 0


def mismatch_of(transaction: Transaction, packet: Response) -> str:
    """What makes ``packet`` no answer to ``transaction`` ("" if nothing does)."""
    if type(packet) is not transaction.response_class:
        return f"{packet.kind} does not answer a {transaction.request.kind}"
    source = packet.source_id
    if source != transaction.destination_id and not same_node(source, transaction.destination_id):
        return (
            f"source {packet.source_id:#06x} is not the destination "
            f"{transaction.destination_id:#06x}"
        )
    if isinstance(packet, LockResponse):
        request = transaction.request
        assert isinstance(request, LockRequest)
        if packet.extended_tcode != request.extended_tcode:
            return f"extended tcode {packet.extended_tcode:#x} != {request.extended_tcode:#x}"
    # Only a successful response carries data; an error response may carry none.
    if transaction.length >= 0 and packet.rcode == RCode.resp_complete:
        assert isinstance(packet, (BlockReadResponse, LockResponse))
        if packet.data_length != transaction.length or len(packet.data) != packet.data_length:
            return (
                f"{len(packet.data)} bytes (data_length {packet.data_length}), "
                f"expected {transaction.length}"
            )
    return ""


def completion(transaction: Transaction, packet: Response) -> Event:
    """The event of a transaction that ``packet`` (matched, resp_complete) completes."""
    tid = transaction.tid
    if isinstance(packet, QuadletReadResponse):
        return ReadCompleted(tid, packet.quadlet_data.to_bytes(4, "big"))
    if isinstance(packet, BlockReadResponse):
        return ReadCompleted(tid, packet.data)
    if isinstance(packet, LockResponse):
        return LockCompleted(tid, packet.data)
    return WriteCompleted(tid)
