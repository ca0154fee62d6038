"""The matching step of :mod:`fw1394.capture.analysis.transactions`, on plain key columns.

Requests and responses are put in one sequence sorted by (epoch, requester,
responder, tlabel) and then by record order, so every decision compares an
event with its neighbour: retries follow the busy-acked attempt they repeat,
and a response follows the request it answers.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from fw1394.capture.analysis.transaction_model import (
    BROADCAST_NODE,
    I64,
    IS_CLOSING_ACK,
    IS_RETRY_ACK,
)

Columns = Mapping[str, np.ndarray]


def key(
    epoch: np.ndarray, requester: np.ndarray, responder: np.ndarray, tl: np.ndarray
) -> np.ndarray:
    """One int64 per event: equal exactly when the four matching fields are."""
    packed: np.ndarray = (((epoch << 16 | requester) << 16 | responder) << 6) | tl
    return packed


@dataclass
class Sequence:
    """Transactions found among the requests, and the responses that answered them."""

    first: np.ndarray  # request row of the first attempt
    last: np.ndarray  # request row of the last attempt
    attempts: np.ndarray
    busy: np.ndarray
    problems: np.ndarray
    answer: np.ndarray  # response row, or -1
    reused: np.ndarray  # the label came back in a new request before any answer


def match(requests: Columns, responses: Columns) -> Sequence:
    """Group retries into transactions and pair each with the response that follows it."""
    n_req = len(requests["ordinal"])
    if not n_req:
        nothing = np.zeros(0, I64)
        return Sequence(nothing, nothing, nothing, nothing, nothing, nothing, np.zeros(0, bool))
    keys = np.concatenate(
        [
            key(
                requests["epoch"], requests["requester"], requests["responder"], requests["tlabel"]
            ),
            key(
                responses["epoch"],
                responses["requester"],
                responses["responder"],
                responses["tlabel"],
            ),
        ]
    )
    ordinal = np.concatenate([requests["ordinal"], responses["resp_ordinal"]])
    order = np.lexsort((ordinal, keys))
    total = len(order)
    k = keys[order]
    is_request = order < n_req
    rows = np.where(is_request, order, 0)
    ack = np.where(is_request, requests["ack"][rows], -1)
    tcode = np.where(is_request, requests["tcode"][rows], -1)
    same = np.zeros(total, bool)  # same[p]: event p has the key of event p - 1
    same[1:] = k[1:] == k[:-1]
    retry = np.zeros(total, bool)
    retry[1:] = (
        same[1:]
        & is_request[:-1]
        & is_request[1:]
        & IS_RETRY_ACK[ack[:-1]]
        & (tcode[1:] == tcode[:-1])
    )
    start_pos = np.flatnonzero(is_request & ~retry)
    last_pos = np.flatnonzero(is_request & ~np.append(retry[1:], False))
    following = np.minimum(last_pos + 1, max(total - 1, 0))
    continues = (last_pos + 1 < total) & np.append(same[1:], False)[last_pos]
    closed = IS_CLOSING_ACK[ack[last_pos]]
    answered = continues & ~is_request[following] & ~closed

    def per_transaction(name: str, reduce: np.ufunc) -> np.ndarray:
        values = np.where(is_request, requests[name][rows], 0)
        totals: np.ndarray = reduce.reduceat(values, start_pos) if len(start_pos) else values[:0]
        return totals

    return Sequence(
        first=order[start_pos],
        last=order[last_pos],
        attempts=per_transaction("attempts", np.add),
        busy=per_transaction("busy", np.add),
        problems=per_transaction("problems", np.bitwise_or),
        answer=np.where(answered, order[following] - n_req, -1),
        reused=continues & is_request[following],
    )


def match_broadcast(requests: Columns, responses: Columns, found: Sequence) -> None:
    """Pair leftover responses with open broadcast requests (one node answers for all)."""
    taken = np.zeros(len(responses["resp_ordinal"]), bool)
    taken[found.answer[found.answer >= 0]] = True
    responder = requests["responder"][found.last]
    open_broadcast = np.flatnonzero(
        (found.answer < 0) & ((responder & BROADCAST_NODE) == BROADCAST_NODE)
    )
    loose = np.flatnonzero(~taken)
    if not len(open_broadcast) or not len(loose):
        return
    rows = found.last[open_broadcast]
    keys = np.concatenate(
        [
            key(
                requests["epoch"][rows],
                requests["requester"][rows],
                requests["responder"][rows],
                requests["tlabel"][rows],
            ),
            key(
                responses["epoch"][loose],
                responses["requester"][loose],
                responses["responder"][loose] | BROADCAST_NODE,
                responses["tlabel"][loose],
            ),
        ]
    )
    ordinal = np.concatenate([requests["ordinal"][rows], responses["resp_ordinal"][loose]])
    is_request = np.concatenate([np.ones(len(rows), bool), np.zeros(len(loose), bool)])
    which = np.concatenate([open_broadcast, loose])
    order = np.lexsort((ordinal, keys))
    k, request, r = keys[order], is_request[order], which[order]
    hit = np.flatnonzero(request[:-1] & ~request[1:] & (k[1:] == k[:-1]))
    found.answer[r[hit]] = r[hit + 1]
    found.reused[r[hit]] = False


__all__ = ["I64", "Sequence", "key", "match", "match_broadcast"]
