"""The sans-IO transaction engine: requester (host side) and responder (node side).

No sockets and no clock: packets, bytes and the time go in; packets, replies and
events come out. ``API.md`` in this package is the contract; the decisions live
in :mod:`fw1394.engine.table`; :mod:`fw1394.engine.loopback` wires both sides
together in memory for tests and benchmarks.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Event": "fw1394.engine.events",
    "FailureReason": "fw1394.engine.events",
    "LockCompleted": "fw1394.engine.events",
    "ReadCompleted": "fw1394.engine.events",
    "TransactionEvent": "fw1394.engine.events",
    "TransactionFailed": "fw1394.engine.events",
    "UnexpectedAck": "fw1394.engine.events",
    "UnexpectedResponse": "fw1394.engine.events",
    "WriteCompleted": "fw1394.engine.events",
    "Link": "fw1394.engine.loopback",
    "IEEE1394_NODE": "fw1394.engine.policy",
    "JHU_FIRMWARE": "fw1394.engine.policy",
    "THESIS_FPGA": "fw1394.engine.policy",
    "ResponderPolicy": "fw1394.engine.policy",
    "Requester": "fw1394.engine.requester",
    "Reply": "fw1394.engine.responder",
    "Responder": "fw1394.engine.responder",
}

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

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
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
