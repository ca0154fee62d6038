"""Boards addressed by board ID, resolved to a physical ID per bus generation.

A bus reset renumbers physical IDs (the member table is sorted anew when a
board leaves or comes back), so a physical ID is a name for one generation
only. :class:`BoardPort` is a :class:`~fw1394.host.port.Port` whose node
numbers are board IDs (the rotary switch each member announces): every call
looks the board up in the member table of the current generation and pins
the transaction to that generation. A call that meets a reset before it goes
out (:class:`~fw1394.transport.bus_host.StaleGenerationError`) is resolved
again and retried, since nothing was sent; the new physical ID is logged on
the ``fw1394.host`` logger and kept in :attr:`BoardPort.resolutions`. A
reset while a transaction is on the bus still fails it with ``bus_reset``
(for a write, the outcome may be unknown), and a board that is not on the
bus raises :class:`BoardNotOnBusError`.

``Board(BoardPort(port), board_id)`` is then a :class:`~fw1394.host.robot.RobotIO`
addressed by board ID. ``port`` is an
:class:`~fw1394.host.adapter_port.AdapterPort` or a
:class:`~fw1394.host.bus_port.BusPort`.
"""

from __future__ import annotations

import logging
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol, TypeVar

from fw1394.errors import BusUnreachable
from fw1394.transport.bus_host import StaleGenerationError
from fw1394.transport.sansio.wire import NO_BOARD, MemberInfo

log = logging.getLogger("fw1394.host")
T = TypeVar("T")
#: Resets in a row a call rides out before it gives up with the last stale error.
_ATTEMPTS = 4


class BoardNotOnBusError(BusUnreachable, LookupError):
    """No member of the bus has that board ID now (or more than one has)."""


class PinnablePort(Protocol):
    """A port whose calls take the generation they are addressed in."""

    @property
    def generation(self) -> int: ...

    def table(self) -> tuple[int, tuple[MemberInfo, ...]]: ...

    def read_quadlet(self, node: int, offset: int, *, generation: int | None = None) -> int: ...

    def write_quadlet(
        self, node: int, offset: int, value: int, *, generation: int | None = None
    ) -> None: ...

    def read_block(
        self, node: int, offset: int, length: int, *, generation: int | None = None
    ) -> bytes: ...

    def write_block(
        self, node: int, offset: int, data: bytes, *, generation: int | None = None
    ) -> None: ...

    def lock(
        self,
        node: int,
        offset: int,
        extended_tcode: int,
        argument: bytes,
        data: bytes,
        *,
        generation: int | None = None,
    ) -> bytes: ...


@dataclass(frozen=True, slots=True)
class Resolution:
    """Board ``board_id`` is physical ID ``phy`` in ``generation`` (None: not on the bus)."""

    board_id: int
    generation: int
    phy: int | None
    previous: int | None


def board_phys(members: tuple[MemberInfo, ...]) -> dict[int, list[int]]:
    """Board ID -> the physical IDs of the members announcing it, hosts left out."""
    found: dict[int, list[int]] = {}
    for phy, member in enumerate(members):
        if not member.host and member.board_id != NO_BOARD:
            found.setdefault(member.board_id, []).append(phy)
    return found


class BoardPort:
    """A :class:`~fw1394.host.port.Port` over ``port`` whose node numbers are board IDs."""

    def __init__(self, port: PinnablePort) -> None:
        self.port = port
        self._generation: int | None = None
        self._boards: dict[int, list[int]] = {}
        #: The member table of the latest look-up, in physical-ID order.
        self.members: tuple[MemberInfo, ...] = ()
        #: The latest resolutions that changed a board's physical ID or generation.
        self.resolutions: deque[Resolution] = deque(maxlen=256)
        #: Board ID -> (generation, physical ID) it was last resolved to.
        self._known: dict[int, tuple[int, int | None]] = {}

    def locate(self, board_id: int) -> tuple[int, int]:
        """(physical ID, generation) of ``board_id`` now."""
        fresh = self._generation is None or self._generation != self.port.generation
        if fresh:
            self._refresh()
        phys = self._boards.get(board_id, [])
        if len(phys) != 1 and not fresh:
            # Not (or not only) there as of the last look: news may be waiting.
            self._refresh()
            phys = self._boards.get(board_id, [])
        assert self._generation is not None
        if len(phys) != 1:
            self._note(board_id, None)
            boards = ", ".join(str(b) for b in sorted(self._boards)) or "none"
            if phys:
                raise BoardNotOnBusError(
                    f"board ID {board_id} is announced by {len(phys)} members (physical IDs "
                    f"{', '.join(map(str, phys))}) in generation {self._generation}"
                )
            raise BoardNotOnBusError(
                f"no board with board ID {board_id} on the bus in generation "
                f"{self._generation} (board IDs: {boards})"
            )
        self._note(board_id, phys[0])
        return phys[0], self._generation

    def _refresh(self) -> None:
        generation, members = self.port.table()
        self._generation, self._boards = generation, board_phys(members)
        self.members = members

    def _note(self, board_id: int, phy: int | None) -> None:
        generation = self._generation
        assert generation is not None
        known = self._known.get(board_id)
        if known is not None and known == (generation, phy):
            return
        self._known[board_id] = (generation, phy)
        previous = None if known is None else known[1]
        self.resolutions.append(Resolution(board_id, generation, phy, previous))
        if known is not None:  # the first look-up is no news
            log.info(
                "board %d: %s in generation %d (was %s in generation %d)",
                board_id,
                _where(phy),
                generation,
                _where(previous),
                known[0],
            )

    def _pinned(self, board_id: int, call: Callable[[int, int], T]) -> T:
        for attempt in range(_ATTEMPTS):
            phy, generation = self.locate(board_id)
            try:
                return call(phy, generation)
            except StaleGenerationError:
                # Nothing was sent: look the board up in the new generation.
                self._generation = None
                if attempt == _ATTEMPTS - 1:
                    raise
        raise AssertionError("unreachable")

    # -- the Port calls, by board ID ----------------------------------------------------
    def read_quadlet(self, node: int, offset: int) -> int:
        port = self.port
        return self._pinned(node, lambda p, g: port.read_quadlet(p, offset, generation=g))

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        port = self.port
        self._pinned(node, lambda p, g: port.write_quadlet(p, offset, value, generation=g))

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        port = self.port
        return self._pinned(node, lambda p, g: port.read_block(p, offset, length, generation=g))

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        port = self.port
        self._pinned(node, lambda p, g: port.write_block(p, offset, data, generation=g))

    def lock(
        self, node: int, offset: int, extended_tcode: int, argument: bytes, data: bytes
    ) -> bytes:
        """The old value at ``offset`` of board ``node`` after a lock."""
        port = self.port
        return self._pinned(
            node, lambda p, g: port.lock(p, offset, extended_tcode, argument, data, generation=g)
        )


def _where(phy: int | None) -> str:
    return "not on the bus" if phy is None else f"physical ID {phy}"
