"""Board kinds: one package each (``snake2010``, ``qla1``, ``memory``), one registry.

See :mod:`fw1394.boards.registry`, :mod:`fw1394.boards.regmap` and
``docs/boards/adding-a-board.md``.
"""

from fw1394.boards.registry import BOARDS, BoardKind, board_kind, make_board

__all__ = ["BOARDS", "BoardKind", "board_kind", "make_board"]
