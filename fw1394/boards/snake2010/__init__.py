"""The 2010 Snake Robot's FPGA board: axes, pots, amplifiers and their physics.

``docs/boards/snake2010.md`` describes the board; :class:`Snake2010Board` is one
board's address space.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Snake2010Board": "fw1394.boards.snake2010.board",
}

__all__ = [
    "Snake2010Board",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.boards.snake2010.board import Snake2010Board
