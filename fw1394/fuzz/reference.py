"""The reference model: what a correct node of the same kind answers, case by case.

The model is a second, independent instance of the target's board kind behind
a :class:`~fw1394.engine.Responder` that follows the contract. It receives
every packet the target receives, at the same time, and the responder lets
through to the board exactly the writes the contract accepts; so its answers
are the expected answers, its registers the expected state.

In-process the target and the model share one clock and the comparison is
exact. A node in another process keeps its own clock, so the model cannot
know time-dependent values (timestamps, a watchdog about to fire, a moving
motor). A twin model then runs beside the first, on a clock that runs at a
different rate: where the two disagree the answer depends on time, and only
what does not (ack, rcode, lengths, routing) is compared.
"""

from __future__ import annotations

from enum import IntEnum

from fw1394.boards import make_board
from fw1394.boards.registry import board_defects
from fw1394.engine import Reply, Responder, ResponderPolicy
from fw1394.engine.space import AddressSpace
from fw1394.packets import AsyncPacket

#: The twin's clock: ``TWIN_RATE * now + TWIN_SHIFT`` (monotonic, and apart).
TWIN_RATE = 1.5
TWIN_SHIFT = 1.0


class Certainty(IntEnum):
    """How much of an expected reply the model vouches for."""

    #: Only that a reply comes, its kind, label and destination (no board model).
    presence = 0
    #: Also ack, rcode, source, length and tenure, but not the data (time-dependent).
    header = 1
    #: Everything, data included.
    exact = 2


class OpenSpace:
    """A node nothing is known about: every access succeeds, reads return zeros."""

    def read_quadlet(self, offset: int) -> int:
        return 0

    def write_quadlet(self, offset: int, value: int) -> None:
        pass

    def read_block(self, offset: int, length: int) -> bytes:
        return bytes(length)

    def write_block(self, offset: int, data: bytes) -> None:
        pass

    def set_time(self, ticks: int) -> None:
        pass


def board(kind: str | None, board_id: int, defects: frozenset[str] = frozenset()) -> AddressSpace:
    """A fresh board of ``kind`` (``None``: an :class:`OpenSpace`)."""
    if kind is None:
        return OpenSpace()
    return make_board(kind, board_id=board_id, defects=board_defects(kind, defects))


class Reference:
    """The expected replies of node ``node_id`` of board ``kind`` under ``policy``."""

    def __init__(
        self,
        kind: str | None,
        board_id: int,
        node_id: int,
        policy: ResponderPolicy,
        *,
        twin: bool = False,
    ) -> None:
        self.kind = kind
        self.policy = policy
        self.node_id = node_id
        self.model = Responder(node_id, board(kind, board_id), policy)
        self.twin = Responder(node_id, board(kind, board_id), policy) if twin else None
        self._ceiling = Certainty.exact if kind is not None else Certainty.presence

    def expect(
        self, packet: AsyncPacket | None, damaged: bool, now: float
    ) -> tuple[Reply, Certainty]:
        """The reply the contract asks for, and how far the model vouches for it."""
        if packet is None:
            return _SILENT, self._ceiling
        reply = self.model.receive_packet(packet, now, damaged=damaged)
        twin = self.twin
        if twin is None:
            return reply, self._ceiling
        other = twin.receive_packet(packet, TWIN_RATE * now + TWIN_SHIFT, damaged=damaged)
        if other == reply:
            return reply, self._ceiling
        if other.ack != reply.ack or _rcode(other) != _rcode(reply):
            return reply, Certainty.presence
        return reply, min(self._ceiling, Certainty.header)

    def renumber(self, node_id: int) -> None:
        """The target took a new node ID (a bus reset)."""
        self.node_id = node_id
        self.model.bus_reset(node_id=node_id, generation=self.model.generation + 1)
        if self.twin is not None:
            self.twin.bus_reset(node_id=node_id, generation=self.twin.generation + 1)


_SILENT = Reply(None, None, False)


def _rcode(reply: Reply) -> int | None:
    return getattr(reply.response, "rcode", None)
