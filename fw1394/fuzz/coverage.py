"""Functional coverage of a campaign: which kinds of case met which outcome.

Each case falls in one bin: its packet kind (tcode) x the outcome the node
gave (silence, ack_complete, ack_pending, another ack, a response alone) x the
speed it was delivered at (rtl: targets; ``-`` elsewhere) x its length class x
whom it was addressed to. The bins worth hitting are the requests the
contracts talk about, each with the lengths it can carry, under every outcome,
speed and address; the report lists the ones never hit.
"""

from __future__ import annotations

from collections import Counter
from itertools import product

from fw1394.fuzz.target import Observed
from fw1394.packets import AckCode, AsyncPacket, QuadletWriteRequest

OUTCOMES = ("silence", "ack_complete", "ack_pending", "ack_error", "response-only")
ADDRESSES = ("ours", "broadcast", "other-node", "other-bus")
#: Request kinds, and the length classes each can carry.
REQUEST_LENGTHS = {
    "read_quadlet_request": ("none",),
    "write_quadlet_request": ("quadlet",),
    "read_block_request": ("empty", "short", "long", "oversize"),
    "write_block_request": ("empty", "short", "long", "oversize"),
    "lock_request": ("short", "long", "oversize"),
}
#: Longest block the thesis and JHU boards serve, bytes.
_LONG = 2048
_SHORT = 64


def outcome(seen: Observed) -> str:
    if seen.ack is None:
        return "silence" if seen.response is None else "response-only"
    if seen.ack == AckCode.ack_complete:
        return "ack_complete"
    if seen.ack == AckCode.ack_pending:
        return "ack_pending"
    return "ack_error"


def length_class(packet: AsyncPacket | None) -> str:
    if isinstance(packet, QuadletWriteRequest):
        return "quadlet"
    length: int | None = getattr(packet, "data_length", None)
    if length is None:
        return "none"
    if length == 0:
        return "empty"
    return "short" if length <= _SHORT else "long" if length <= _LONG else "oversize"


def bin_name(kind: str, result: str, speed: str, length: str, address: str) -> str:
    return "/".join((kind, result, speed, length, address))


def space(speeds: tuple[str, ...]) -> list[str]:
    """Every bin worth hitting, for a campaign at ``speeds``."""
    return [
        bin_name(kind, result, speed, length, address)
        for kind, lengths in REQUEST_LENGTHS.items()
        for result, speed, length, address in product(OUTCOMES, speeds, lengths, ADDRESSES)
    ]


def never_hit(hits: Counter[str], speeds: tuple[str, ...]) -> list[str]:
    return [name for name in space(speeds) if not hits[name]]
