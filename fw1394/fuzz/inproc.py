"""``inproc:BOARD``: the board emulator and its responder in the fuzzer's own process.

The fastest target: packets are handed over already decoded, on the fuzzer's
clock, so the reference model runs in lockstep and compares exactly.
"""

from __future__ import annotations

from fw1394.engine import ResponderPolicy
from fw1394.engine.defects import DefectiveResponder
from fw1394.fuzz.reference import board
from fw1394.fuzz.target import SILENCE, Observed, TargetCrash, Visibility, Wire


class InprocTarget:
    """Board ``kind`` as node ``node_id`` answering as ``policy``, with planted ``defects``."""

    visibility = Visibility()
    needs_fence = False
    restartable = True

    def __init__(
        self,
        kind: str,
        *,
        board_id: int,
        node_id: int,
        policy: ResponderPolicy,
        defects: frozenset[str] = frozenset(),
    ) -> None:
        self.kind = kind
        self.board_id = board_id
        self.node_id = node_id
        self.policy = policy
        self.defects = defects
        self.description = f"inproc:{kind}"
        self.responder = self._fresh()

    def _fresh(self) -> DefectiveResponder:
        space = board(self.kind, self.board_id, self.defects)
        return DefectiveResponder(self.node_id, space, self.policy, defects=self.defects)

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        receive = self.responder.receive_packet
        out: list[Observed] = []
        for wire in batch:
            if wire.packet is None:
                out.append(SILENCE)
                continue
            try:
                out.append(receive(wire.packet, now, damaged=wire.damaged))
            except Exception as error:  # the node's own bug: that is the finding
                raise TargetCrash(f"raised {type(error).__name__}: {error}") from error
        return out

    def problem(self) -> str | None:
        return None

    def restart(self) -> None:
        self.responder = self._fresh()

    def close(self) -> None:
        pass
