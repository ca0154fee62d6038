"""A memory board that records the board time each request brings it (the link tests)."""

from __future__ import annotations

from fw1394.boards.memory.board import MemorySpace


class ClockedSpace(MemorySpace):
    """Memory that records the board time it is told (49.152 MHz ticks)."""

    def __init__(self) -> None:
        super().__init__(4096)
        self.clock: list[int] = []

    def set_time(self, ticks: int) -> None:
        self.clock.append(ticks)
        super().set_time(ticks)
