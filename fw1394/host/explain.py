"""Why a board left a request unanswered, from what its kind is known to serve.

A bare "no ack" tells a user nothing when the node is there and well: the
thesis FPGA simply ignores every tcode but quadlet and block reads and
writes (§6.1), locks included. The board registry names each kind's
responder policy (:data:`fw1394.engine.policy.POLICIES`); the policy says
which tcodes it serves and what it does with the others.
"""

from __future__ import annotations

from fw1394.boards.registry import BOARDS
from fw1394.engine.policy import POLICIES, ResponderPolicy
from fw1394.packets import TCode, name_of
from fw1394.packets.tcodes import REQUEST_TCODES

#: Requests every responder policy serves.
ALWAYS_SERVED = frozenset(
    {
        TCode.read_quadlet_request,
        TCode.read_block_request,
        TCode.write_quadlet_request,
        TCode.write_block_request,
    }
)


def served_tcodes(policy: ResponderPolicy) -> frozenset[TCode]:
    """The request tcodes a node with ``policy`` performs."""
    return ALWAYS_SERVED | {TCode.lock_request} if policy.locks else ALWAYS_SERVED


def unserved(kind: str | None, tcode: int) -> str | None:
    """Why a ``kind`` board does not perform ``tcode`` requests; None if it does (or unknown)."""
    entry = BOARDS.get(kind or "")
    if entry is None:
        return None
    if tcode not in REQUEST_TCODES:
        # Stream and cycle-start packets, responses: nothing a node acks or answers.
        return f"a {name_of(TCode, tcode)} packet is no request: no node acks or answers it"
    policy = POLICIES[entry.policy]
    served = served_tcodes(policy)
    if tcode in served:
        return None
    answer = (
        "ignores them (no ack, no response)"
        if policy.unsupported_tcode == "silent"
        else "answers them ack_type_error"
    )
    what = ", ".join(name_of(TCode, t).removesuffix("_request") for t in sorted(served))
    return (
        f"a {kind} board does not serve {name_of(TCode, tcode)} packets: its responder "
        f"policy {entry.policy!r} {answer}; it serves {what} requests"
    )
