"""The reference model: what a correct node of the same kind answers, case by case.

The model is a second, independent instance of the target's board kind behind
a :class:`~fw1394.engine.Responder` that follows the contract. It receives
every packet the target receives, at the same time, and the responder lets
through to the board exactly the writes the contract accepts; so its answers
are the expected answers, its registers the expected state.

In-process the target and the model share one clock and the comparison is
exact. A node in another process keeps its own clock, so the model cannot
know time-dependent values (timestamps, a watchdog about to fire, a moving
motor). Twin models then run beside the first, on clocks that run at other
rates: where they disagree the answer depends on time, and only what does
not (ack, rcode, lengths, routing) is compared.

A node reached over another path than FireWire (the JHU boards' Ethernet
path) is given that path's description (:class:`fw1394.boards.qla1.paths.Path`):
the model then reads the bytes, screens the destination, decodes the offset
and shapes the answer as that path does, before and after the board.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import IntEnum

from fw1394.boards import make_board
from fw1394.boards.config_rom import with_config_rom
from fw1394.boards.qla1.paths import Path
from fw1394.boards.registry import BOARDS, board_defects
from fw1394.engine import Reply, Responder, ResponderPolicy
from fw1394.engine.space import AddressSpace
from fw1394.packets import AckCode, AsyncPacket, QuadletReadResponse, Request, Response
from fw1394.packets.nodeid import phy_of

#: The twins' clocks: ``rate * now + shift + step * packets`` (monotonic, and apart
#: from the model's). A remote node sees the gaps between requests stretched or
#: squeezed by scheduling on a loaded machine, and time passes between the packets
#: of one batch (which the model sees at one instant): one twin runs 4 times faster
#: and a few ms further per packet, one 4 times slower (a watchdog firing on the
#: node and not in the model, or the other way round).
TWIN_CLOCKS = ((4.0, 1.0, 0.005), (0.25, 1.0, 0.0))


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


@dataclass(frozen=True)
class RomIdentity:
    """Who a node process on a bus is, which its configuration ROM says
    (:func:`fw1394.boards.config_rom.with_config_rom`)."""

    bus: str
    board_id: int
    rank: int | None

    def dress(self, space: AddressSpace, kind: str | None) -> AddressSpace:
        """``space`` as the node process serves it: a board without a ROM of its own
        (no node program of its kind) is behind the generic ROM."""
        if kind is None or BOARDS[kind].node_program is not None:
            return space
        return with_config_rom(
            space, bus=self.bus, board_id=self.board_id, rank=self.rank, model=kind
        )


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
        path: Path | None = None,
        rom: RomIdentity | None = None,
    ) -> None:
        self.kind = kind
        self.path = path
        self.policy = policy if path is None else path.policy
        self.node_id = node_id
        self.board_id = board_id

        def fresh() -> AddressSpace:
            space = board(kind, board_id)
            return space if rom is None else rom.dress(space, kind)

        self.model = Responder(node_id, fresh(), self.policy)
        self.twins = [
            Responder(node_id, fresh(), self.policy) for _ in (TWIN_CLOCKS if twin else ())
        ]
        self._ceiling = Certainty.exact if kind is not None else Certainty.presence
        self._packets = 0
        #: What the last quadlet read returned: a stale-data read's answer.
        self._last_read = 0

    def expect(
        self, packet: AsyncPacket | None, damaged: bool, now: float, *, raw: bytes | None = None
    ) -> tuple[Reply, Certainty]:
        """The reply the contract asks for, and how far the model vouches for it.

        ``raw``: the bytes as sent, which a path other than FireWire reads its own way.
        """
        path = self.path
        stale = None
        if path is not None:
            if raw is not None:
                stale = path.stale_read(raw)
                packet, damaged = (stale, False) if stale is not None else path.read(raw)
            damaged = damaged and path.checks_crc
            if not isinstance(packet, Request) or not path.takes(packet, self.board_id):
                return _SILENT, self._ceiling
            packet = path.for_board(packet, phy_of(self.node_id))
        if packet is None:
            return _SILENT, self._ceiling
        if stale is not None and path is not None:
            # No register is read: the answer carries what the previous read returned.
            response = path.stale_response(stale, self._last_read)
            concatenated = self.policy.read_mode == "concatenated"
            reply = Reply(AckCode.ack_pending, response, concatenated)
            return self._shaped(packet, reply), self._ceiling
        reply = self._shaped(packet, self.model.receive_packet(packet, now, damaged=damaged))
        if isinstance(reply.response, QuadletReadResponse):
            self._last_read = reply.response.quadlet_data
        certainty = self._ceiling
        # No twins (a node restarted with the model): the comparison is exact.
        self._packets += 1
        for twin, (rate, shift, step) in zip(self.twins, TWIN_CLOCKS, strict=False):
            when = rate * now + shift + step * self._packets
            other = self._shaped(packet, twin.receive_packet(packet, when, damaged=damaged))
            if other == reply:
                continue
            if other.ack != reply.ack or _rcode(other) != _rcode(reply):
                certainty = Certainty.presence
            certainty = min(certainty, Certainty.header)
        return reply, certainty

    def _shaped(self, request: AsyncPacket, reply: Reply) -> Reply:
        """``reply`` as it leaves over the path (the Ethernet path's source ID)."""
        path, response = self.path, reply.response
        if path is None or not isinstance(response, Response):
            return reply
        assert isinstance(request, Request)
        return Reply(reply.ack, path.answer(response, request, self.board_id), reply.concatenated)

    def renumber(self, node_id: int) -> None:
        """The target took a new node ID (a bus reset)."""
        self.node_id = node_id
        self.model.bus_reset(node_id=node_id, generation=self.model.generation + 1)
        for twin in self.twins:
            twin.bus_reset(node_id=node_id, generation=twin.generation + 1)


_SILENT = Reply(None, None, False)


def _rcode(reply: Reply) -> int | None:
    return getattr(reply.response, "rcode", None)
