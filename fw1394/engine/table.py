"""Every decision the engine makes, written down as data.

A responder takes an incoming request through the screens of :data:`SCREENS`
in their order (link-layer checks first, then the transaction layer); the first
screen that applies decides the answer. A request that passes every screen is
served by the address space, and what came of that (an :class:`Outcome`) picks
the answer from :data:`ANSWERS`, keyed by how the node delivers results. The
requester reacts to an ack through :data:`ON_ACK` and chooses the retry code of
a busy retry from :data:`RETRY_CODES`.

The other engine modules only walk these tables, so this is the module to read
(and to change) for how fw1394 behaves on the bus; ``docs/engine.md`` draws
each path as a sequence diagram.
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import Enum
from typing import Final, NamedTuple

from fw1394.engine.events import FailureReason
from fw1394.packets import AckCode, RCode, Retry, TCode
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS, bus_of, phy_of
from fw1394.packets.tcodes import RESPONSE_OF_REQUEST


class Answer(NamedTuple):
    """What a node sends back for one request."""

    #: The ack code; ``None`` is silence (no ack at all).
    ack: AckCode | None
    #: The rcode of the response packet; ``None`` when no response follows.
    rcode: RCode | None = None
    #: The response follows the ack in the same bus tenure.
    concatenated: bool = False


SILENCE: Final = Answer(None)


# -- responder: screens -----------------------------------------------------------------
class Screen(Enum):
    """Reasons to answer a request without serving it, in the order they are checked."""

    #: No packet can be made of the bytes (header cut short, reserved tcode).
    undecodable = "undecodable"
    #: A response, stream packet or cycle start: nothing for a responder to serve.
    not_a_request = "not_a_request"
    #: Another node's request (and not a broadcast).
    not_addressed = "not_addressed"
    #: A tcode the node does not implement, on a node that ignores such packets
    #: (decided from the header, before the CRC is known; also every broadcast).
    unsupported_silent = "unsupported_silent"
    #: Bad CRC or length, on a node that drops damaged packets; also a bad header
    #: CRC on a node that does not trust such a header (not even its destination).
    damaged_dropped = "damaged_dropped"
    #: Bad CRC or length, acked as such (a write may still have been performed).
    damaged_acked = "damaged_acked"
    #: Bad CRC or length on a broadcast: never acked (a write may be performed).
    damaged_broadcast = "damaged_broadcast"
    #: A broadcast write: performed, never acked.
    broadcast_write = "broadcast_write"
    #: A broadcast read or lock: ignored.
    broadcast_other = "broadcast_other"
    #: A tcode the node does not implement, on a node that says so.
    unsupported_acked = "unsupported_acked"
    #: Busy injected for a test or a fault: refused, to be retried.
    injected_busy = "injected_busy"


class Addressee(Enum):
    """Whom a request's destination ID names, as seen by one node."""

    this_node = "this_node"
    broadcast = "broadcast"
    #: Another node, or this node's physical ID on another bus (Screen.not_addressed).
    other = "other"


def addressee(destination_id: int, node_id: int, ignore_bus_id: bool) -> Addressee:
    """Whom ``destination_id`` names for the node ``node_id``: the address screen.

    The bus part must name the local bus or this node's bus, unless the node
    ignores it (``ignore_bus_id``, as the thesis and JHU boards do). Physical ID
    63 is everyone's (a broadcast), whatever this node's own physical ID.
    """
    phy = phy_of(destination_id)
    broadcast = phy == BROADCAST_PHY
    if not broadcast and phy != phy_of(node_id):
        return Addressee.other
    bus = bus_of(destination_id)
    if not (bus == LOCAL_BUS or ignore_bus_id or bus == bus_of(node_id)):
        return Addressee.other
    return Addressee.broadcast if broadcast else Addressee.this_node


SCREENS: Final[dict[Screen, Answer]] = {
    Screen.undecodable: SILENCE,
    Screen.not_a_request: SILENCE,
    Screen.not_addressed: SILENCE,
    Screen.unsupported_silent: SILENCE,
    Screen.damaged_dropped: SILENCE,
    Screen.damaged_acked: Answer(AckCode.ack_data_error),
    Screen.damaged_broadcast: SILENCE,
    Screen.broadcast_write: SILENCE,
    Screen.broadcast_other: SILENCE,
    Screen.unsupported_acked: Answer(AckCode.ack_type_error),
    # The injected code may be ack_busy_A or ack_busy_B instead (dual-phase tests).
    Screen.injected_busy: Answer(AckCode.ack_busy_X),
}


# -- responder: answers -----------------------------------------------------------------
class Delivery(Enum):
    """How a node delivers the result of a request of one kind."""

    #: ack_pending, then the response at once without releasing the bus (thesis reads).
    concatenated = "concatenated"
    #: ack_pending now; the response later, as a subaction of its own.
    split = "split"
    #: The ack is the whole answer; no response packet (thesis writes).
    unified = "unified"


class Outcome(Enum):
    """What serving a request produced, as the node's policy classifies it."""

    done = "done"
    #: AddressError on a node that reports it in the ack.
    address_error_ack = "address_error_ack"
    #: AddressError on a node that reports it in the response's rcode.
    address_error_rcode = "address_error_rcode"
    data_error = "data_error"
    type_error = "type_error"
    #: A SpaceError of no more specific kind: a resource conflict.
    conflict_error = "conflict_error"
    busy = "busy"


def _with_response(concatenated: bool) -> dict[Outcome, Answer]:
    pending = AckCode.ack_pending
    return {
        Outcome.done: Answer(pending, RCode.resp_complete, concatenated),
        Outcome.address_error_ack: Answer(AckCode.ack_address_error),
        Outcome.address_error_rcode: Answer(pending, RCode.resp_address_error, concatenated),
        Outcome.data_error: Answer(pending, RCode.resp_data_error, concatenated),
        Outcome.type_error: Answer(pending, RCode.resp_type_error, concatenated),
        Outcome.conflict_error: Answer(pending, RCode.resp_conflict_error, concatenated),
        Outcome.busy: Answer(AckCode.ack_busy_X),
    }


ANSWERS: Final[dict[Delivery, dict[Outcome, Answer]]] = {
    Delivery.concatenated: _with_response(concatenated=True),
    Delivery.split: _with_response(concatenated=False),
    # Without a response packet only the ack can carry an error, whatever the
    # node's preference for rcodes (IEEE 1394 allows every error ack as a final ack).
    Delivery.unified: {
        Outcome.done: Answer(AckCode.ack_complete),
        Outcome.address_error_ack: Answer(AckCode.ack_address_error),
        Outcome.address_error_rcode: Answer(AckCode.ack_address_error),
        Outcome.data_error: Answer(AckCode.ack_data_error),
        Outcome.type_error: Answer(AckCode.ack_type_error),
        Outcome.conflict_error: Answer(AckCode.ack_conflict_error),
        Outcome.busy: Answer(AckCode.ack_busy_X),
    },
}


# -- requester --------------------------------------------------------------------------
class Step(Enum):
    """What the requester does with a transaction after its ack."""

    complete = "complete"
    await_response = "await_response"
    retry = "retry"
    fail = "fail"


class Reaction(NamedTuple):
    step: Step
    reason: FailureReason | None = None
    detail: str = ""


_NO_RESPONSE_WILL_FOLLOW = Reaction(
    Step.fail, FailureReason.response_mismatch, "ack_complete: no response will follow"
)

#: (the request expects a response packet, ack code) -> reaction. A write expects
#: none: ack_complete ends it (unified); reads and locks need their data.
#: A code missing from the table (or no ack at all) is a missing ack: the standard
#: treats an ack it cannot understand like one that never came.
ON_ACK: Final[dict[tuple[bool, int], Reaction]] = {
    (False, AckCode.ack_complete): Reaction(Step.complete),
    (True, AckCode.ack_complete): _NO_RESPONSE_WILL_FOLLOW,
    **{
        (expects, ack): reaction
        for expects in (False, True)
        for ack, reaction in {
            AckCode.ack_pending: Reaction(Step.await_response),
            AckCode.ack_busy_X: Reaction(Step.retry),
            AckCode.ack_busy_A: Reaction(Step.retry),
            AckCode.ack_busy_B: Reaction(Step.retry),
            # 1394a: the node is suspended; it asks to be asked again, like busy.
            AckCode.ack_tardy: Reaction(Step.retry),
            AckCode.ack_conflict_error: Reaction(Step.fail, FailureReason.ack_conflict_error),
            AckCode.ack_data_error: Reaction(Step.fail, FailureReason.ack_data_error),
            AckCode.ack_type_error: Reaction(Step.fail, FailureReason.ack_type_error),
            AckCode.ack_address_error: Reaction(Step.fail, FailureReason.ack_address_error),
        }.items()
    },
}
MISSING_ACK: Final = Reaction(Step.fail, FailureReason.no_ack)

#: (retry protocol, busy ack) -> retry code of the retransmission. Single-phase
#: retry answers every busy with retry_X; dual-phase echoes the phase the
#: responder named, and falls back to retry_X for a single-phase responder.
RETRY_CODES: Final[dict[tuple[str, int], Retry]] = {
    ("single", AckCode.ack_busy_X): Retry.retry_X,
    ("single", AckCode.ack_busy_A): Retry.retry_X,
    ("single", AckCode.ack_busy_B): Retry.retry_X,
    ("single", AckCode.ack_tardy): Retry.retry_X,
    ("dual", AckCode.ack_busy_X): Retry.retry_X,
    ("dual", AckCode.ack_busy_A): Retry.retry_A,
    ("dual", AckCode.ack_busy_B): Retry.retry_B,
    ("dual", AckCode.ack_tardy): Retry.retry_X,
}

#: request tcode -> the tcode its response must carry (defined in packets, named here
#: for the engine).
RESPONSE_TCODES: Final[Mapping[TCode, TCode]] = RESPONSE_OF_REQUEST
