"""Bottom layer of the host library: moving quadlets and blocks to nodes.

The thesis's bottom layer called libraw1394. Here a :class:`Port` is any
object with the four asynchronous operations; :class:`LocalPort` calls
in-process :class:`AddressSpace` objects directly, so host code can drive
board emulators without a bus, with time supplied by a clock callable.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Protocol

from fw1394.engine.space import TICKS_PER_SECOND, AddressSpace
from fw1394.errors import BusUnreachable


class Port(Protocol):
    """Asynchronous 1394 transactions addressed by node number."""

    def read_quadlet(self, node: int, offset: int) -> int:
        """Quadlet read at ``offset`` of ``node``."""
        ...

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        """Quadlet write of ``value`` at ``offset`` of ``node``."""
        ...

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        """Block read of ``length`` bytes at ``offset`` of ``node``."""
        ...

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        """Block write of ``data`` at ``offset`` of ``node``."""
        ...


class UnknownNodeError(BusUnreachable, LookupError):
    """No address space is attached under that node number."""


class ManualClock:
    """A clock in 49.152 MHz ticks that moves only when told to."""

    def __init__(self, ticks: int = 0) -> None:
        self.ticks = ticks

    def __call__(self) -> int:
        return self.ticks

    def advance(self, ticks: int) -> None:
        """Move the clock forward by ``ticks``."""
        if ticks < 0:
            raise ValueError("a clock cannot run backwards")
        self.ticks += ticks

    def advance_seconds(self, seconds: float) -> None:
        """Move the clock forward by ``seconds`` (rounded to whole ticks)."""
        self.advance(round(seconds * TICKS_PER_SECOND))


class LocalPort:
    """A :class:`Port` whose nodes are address spaces in this process.

    Before each transaction the addressed node's clock is set from
    ``clock``, so a board only does work when it is talked to; its model
    still catches up exactly, because the board integrates up to the new
    time. Errors raised by a node (:class:`SpaceError`) reach the caller.
    """

    def __init__(self, nodes: Mapping[int, AddressSpace], clock: Callable[[], int]) -> None:
        self._nodes = dict(nodes)
        self._clock = clock

    @property
    def nodes(self) -> Mapping[int, AddressSpace]:
        """The attached address spaces by node number."""
        return self._nodes

    def sync(self) -> None:
        """Bring every node's clock up to now (for observers, not needed for I/O)."""
        now = self._clock()
        for space in self._nodes.values():
            space.set_time(now)

    def read_quadlet(self, node: int, offset: int) -> int:
        return self._node(node).read_quadlet(offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self._node(node).write_quadlet(offset, value)

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        return self._node(node).read_block(offset, length)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self._node(node).write_block(offset, data)

    def _node(self, node: int) -> AddressSpace:
        try:
            space = self._nodes[node]
        except KeyError:
            raise UnknownNodeError(f"no node {node} on this port") from None
        space.set_time(self._clock())
        return space
