"""A plain memory board: quadlets and blocks anywhere in a window (tests, engine examples).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "MemorySpace": "fw1394.boards.memory.board",
}

__all__ = [
    "MemorySpace",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.boards.memory.board import MemorySpace
