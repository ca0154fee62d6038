"""Registry of the board emulators a virtual node can be built from.

Every factory takes the keyword ``board_id`` (the board's rotary-switch or
configuration identifier) and optionally ``defects``, a frozenset of planted
bug names used by the fuzzer; it returns an :class:`AddressSpace`.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import partial
from typing import Any

from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.spec import Z_THETA_CHANNELS
from fw1394.engine.space import AddressSpace

BOARDS: dict[str, Callable[..., AddressSpace]] = {
    # Actuation unit of the snake robot: seven amplifier channels.
    "snake2010": Snake2010Board,
    # Z-Theta and five-bar stages: the same board populated with four.
    "snake2010-ztheta": partial(Snake2010Board, channels=Z_THETA_CHANNELS),
    # A JHU FPGA1394/QLA controller (firmware 8 unless told otherwise).
    "qla1": Qla1Board,
    # Plain memory: 64 KiB, byte-addressed the IEEE 1394 way.
    "memory": partial(MemorySpace, 65536),
}


def make_board(kind: str, **kw: Any) -> AddressSpace:
    """Build a board of ``kind`` (a key of :data:`BOARDS`) with keywords ``kw``."""
    try:
        factory = BOARDS[kind]
    except KeyError:
        known = ", ".join(sorted(BOARDS))
        raise KeyError(f"unknown board kind {kind!r}; known kinds: {known}") from None
    return factory(**kw)
