"""The board registry: every board kind a node can be, and everything about it.

A board kind is one package under ``fw1394/boards/`` plus one line in
:data:`BOARDS`. The CLI, the node process, the fuzzer and the bench look a
board up here instead of naming it; nothing outside this module decides by a
board's name.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass
from typing import Any, Protocol

from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.memory.regmap import DEFAULT_SIZE as MEMORY_MAP_SIZE
from fw1394.boards.memory.regmap import REGISTER_MAP as MEMORY_MAP
from fw1394.boards.qla1.board import BOARD_DEFECTS as QLA1_DEFECTS
from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.regmap import REGISTER_MAP as QLA1_MAP
from fw1394.boards.regmap import RegisterMap
from fw1394.boards.snake2010.board import BOARD_DEFECTS as SNAKE2010_DEFECTS
from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.regmap import REGISTER_MAP as SNAKE2010_MAP
from fw1394.boards.snake2010.spec import Z_THETA_CHANNELS
from fw1394.engine.defects import PACKET_DEFECTS
from fw1394.engine.faults import FaultConfig
from fw1394.engine.space import AddressSpace
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing


class NodeProgram(Protocol):
    """A kind's own node program: a node that serves more than the bus (Ethernet)."""

    def check(self, *, eth1394: str | None, firmware: int) -> None:
        """Raise ValueError (with the reason) for options no node could start with."""

    def run(
        self,
        *,
        config: BusConfig,
        board_id: int,
        rank: int | None,
        timing: Timing | None,
        faults: FaultConfig | None,
        defects: frozenset[str],
        eth1394: str | None,
        firmware: int,
        quiet: bool,
    ) -> None:
        """Run the node until SIGINT or SIGTERM; ValueError or OSError if it cannot start."""


@dataclass(frozen=True)
class BoardKind:
    """What fw1394 knows about one kind of board."""

    name: str
    #: One line for listings and ``--help``.
    summary: str
    #: Builds the board: keywords ``board_id`` and optionally ``defects``.
    make: Callable[..., AddressSpace]
    #: The responder policy a node of this kind runs with unless told otherwise
    #: (a key of :data:`fw1394.engine.policy.POLICIES`).
    policy: str = "thesis"
    #: Board-level defects ``--defect`` can plant (see ``docs/boards/``).
    defects: frozenset[str] = frozenset()
    #: The board has an Ethernet (JHU Eth1394) side its node process serves too.
    ethernet: bool = False
    #: Runs this kind's node itself instead of the generic node process.
    node_program: NodeProgram | None = None
    #: What the board decodes (see :mod:`fw1394.boards.regmap`); None: nothing known.
    registers: RegisterMap | None = None


class _Qla1Program:
    """The qla1 node program, imported when a qla1 node starts or is checked.

    Its module brings the board's whole Ethernet stack; every other user of the
    registry (a snake2010 node, the command line's parser) goes without it.
    """

    def check(self, *, eth1394: str | None, firmware: int) -> None:
        from fw1394.boards.qla1.busnode import QLA1_NODE

        QLA1_NODE.check(eth1394=eth1394, firmware=firmware)

    def run(self, **options: Any) -> None:
        from fw1394.boards.qla1.busnode import QLA1_NODE

        QLA1_NODE.run(**options)


def _memory(board_id: int = 0, size: int = MEMORY_MAP_SIZE, **_: Any) -> AddressSpace:
    return MemorySpace(size, board_id=board_id)


BOARDS: dict[str, BoardKind] = {
    kind.name: kind
    for kind in (
        BoardKind(
            "snake2010",
            "actuation unit of the 2010 snake robot: seven amplifier channels",
            Snake2010Board,
            defects=SNAKE2010_DEFECTS,
            registers=SNAKE2010_MAP,
        ),
        BoardKind(
            "snake2010-ztheta",
            "Z-Theta and five-bar stages: the snake board populated with four channels",
            lambda **kw: Snake2010Board(channels=Z_THETA_CHANNELS, **kw),
            defects=SNAKE2010_DEFECTS,
            registers=SNAKE2010_MAP.with_copies("channel", range(1, Z_THETA_CHANNELS + 1)),
        ),
        BoardKind(
            "qla1",
            "JHU FPGA1394 + QLA motor controller (firmware 8 unless told otherwise)",
            Qla1Board,
            policy="jhu",
            defects=QLA1_DEFECTS,
            ethernet=True,
            node_program=_Qla1Program(),
            registers=QLA1_MAP,
        ),
        BoardKind(
            "memory",
            "plain memory, 64 KiB, byte-addressed the IEEE 1394 way",
            _memory,
            policy="quick",
            registers=MEMORY_MAP,
        ),
    )
}


def board_kind(kind: str) -> BoardKind:
    """The registry entry of ``kind``; :class:`KeyError` names the known kinds."""
    try:
        return BOARDS[kind]
    except KeyError:
        known = ", ".join(sorted(BOARDS))
        raise KeyError(f"unknown board kind {kind!r}; known kinds: {known}") from None


def make_board(kind: str, **kw: Any) -> AddressSpace:
    """Build a board of ``kind`` (a key of :data:`BOARDS`) with keywords ``kw``."""
    return board_kind(kind).make(**kw)


def known_defects(kind: str | None) -> dict[str, str]:
    """Defect names a node of board ``kind`` accepts, with what each does."""
    known = dict(PACKET_DEFECTS)
    entry = BOARDS.get(kind or "")
    for name in sorted(entry.defects if entry else ()):
        known[name] = f"board defect of {kind} (docs/boards/)"
    return known


def check_defects(kind: str, names: Iterable[str]) -> frozenset[str]:
    """``names`` if a node of ``kind`` knows each; :class:`ValueError` names the first unknown."""
    chosen = frozenset(names)
    unknown = sorted(chosen - known_defects(kind).keys())
    if unknown:
        raise ValueError(f"unknown defect {unknown[0]!r} for {kind}; see `fw1394 fuzz defects`")
    return chosen


def board_defects(kind: str, names: frozenset[str]) -> frozenset[str]:
    """The part of ``names`` the board itself plants (the rest is the responder's)."""
    entry = BOARDS.get(kind)
    return names & entry.defects if entry else frozenset()
