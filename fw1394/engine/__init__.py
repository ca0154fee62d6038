"""The sans-IO transaction engine: requester (host side) and responder (node side).

No sockets and no clock: packets, bytes and the time go in; packets, replies and
events come out. ``API.md`` in this package is the contract; the decisions live
in :mod:`fw1394.engine.table`; :mod:`fw1394.engine.loopback` wires both sides
together in memory for tests and benchmarks.
"""

from fw1394.engine.events import (
    Event,
    FailureReason,
    LockCompleted,
    ReadCompleted,
    TransactionEvent,
    TransactionFailed,
    UnexpectedAck,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.engine.loopback import Link
from fw1394.engine.policy import IEEE1394_NODE, JHU_FIRMWARE, THESIS_FPGA, ResponderPolicy
from fw1394.engine.requester import Requester
from fw1394.engine.responder import Reply, Responder

__all__ = [
    "IEEE1394_NODE",
    "JHU_FIRMWARE",
    "THESIS_FPGA",
    "Event",
    "FailureReason",
    "Link",
    "LockCompleted",
    "ReadCompleted",
    "Reply",
    "Requester",
    "Responder",
    "ResponderPolicy",
    "TransactionEvent",
    "TransactionFailed",
    "UnexpectedAck",
    "UnexpectedResponse",
    "WriteCompleted",
]
