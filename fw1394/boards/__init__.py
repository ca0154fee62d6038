"""Board kinds: one package each (``snake2010``, ``qla1``, ``memory``), one registry.

See :mod:`fw1394.boards.registry`, :mod:`fw1394.boards.regmap` and
``docs/boards/adding-a-board.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "BOARDS": "fw1394.boards.registry",
    "BoardKind": "fw1394.boards.registry",
    "board_kind": "fw1394.boards.registry",
    "make_board": "fw1394.boards.registry",
}

__all__ = ["BOARDS", "BoardKind", "board_kind", "make_board"]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.boards.registry import BOARDS, BoardKind, board_kind, make_board
