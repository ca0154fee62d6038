"""What the transaction engine tells its user: frozen dataclasses, no behaviour."""

from __future__ import annotations

from dataclasses import dataclass
from enum import StrEnum

from fw1394.packets import AsyncPacket


class FailureReason(StrEnum):
    """Why a transaction ended without success."""

    ack_type_error = "ack_type_error"
    ack_data_error = "ack_data_error"
    ack_address_error = "ack_address_error"
    ack_conflict_error = "ack_conflict_error"
    rcode_error = "rcode_error"
    response_timeout = "response_timeout"
    no_ack = "no_ack"
    busy_retries_exhausted = "busy_retries_exhausted"
    bus_reset = "bus_reset"
    response_mismatch = "response_mismatch"


@dataclass(frozen=True, slots=True)
class Event:
    """Base class of engine events."""


@dataclass(frozen=True, slots=True)
class TransactionEvent(Event):
    """An event about one transaction; ``transaction`` is the id its start returned."""

    transaction: int


@dataclass(frozen=True, slots=True)
class ReadCompleted(TransactionEvent):
    """A read ended with data: the quadlet or block in ``data``."""

    data: bytes


@dataclass(frozen=True, slots=True)
class WriteCompleted(TransactionEvent):
    """A write ended with ``resp_complete`` (or ``ack_complete`` for a unified write)."""


@dataclass(frozen=True, slots=True)
class LockCompleted(TransactionEvent):
    """A lock ended: ``old_value`` is what the address held before it."""

    old_value: bytes


@dataclass(frozen=True, slots=True)
class TransactionFailed(TransactionEvent):
    """A transaction ended without success; ``reason`` says why."""

    reason: FailureReason
    #: The response code, for ``rcode_error``.
    rcode: int | None = None
    detail: str = ""
    #: A write or lock that was out on the bus with no answer yet (no ack, no
    #: response, a mismatching response, a bus reset): it may have been performed.
    outcome_unknown: bool = False


@dataclass(frozen=True, slots=True)
class UnexpectedResponse(Event):
    """A response that matches no outstanding transaction (unsolicited, duplicate, late)."""

    packet: AsyncPacket
    detail: str
    #: The transaction that last used this source and label, when one did: the
    #: response is then most likely a late or duplicated answer to it.
    ended_transaction: int | None = None


@dataclass(frozen=True, slots=True)
class UnexpectedAck(Event):
    """An ack (or a missing ack) that follows no request still waiting for one."""

    destination_id: int
    tlabel: int
    #: The ack code, ``None`` for "no ack came".
    ack: int | None
    detail: str
