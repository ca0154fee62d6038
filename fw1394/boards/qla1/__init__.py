"""The JHU QLA1 board (FPGA1394 firmware): registers, the Ethernet path, racks of boards.

``docs/boards/qla1.md`` describes the board; :class:`Qla1Board` is one board's
address space.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Qla1Board": "fw1394.boards.qla1.board",
}

__all__ = [
    "Qla1Board",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.boards.qla1.board import Qla1Board
