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

:class:`GuidPort` does the same by GUID (EUI-64): in each generation it reads
the GUID from the bus information block of every member's configuration ROM
(CSR 0xFFFF_F000_0400, one 20-byte block read pinned to that generation, kept
for as long as the member stays on the bus) and finds the one that matches,
the way Linux's firewire-core keys devices by GUID across resets. Members
without a ROM (or whose ROM read fails) have no GUID.

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
from fw1394.transport.bus_host import StaleGenerationError, TransactionError
from fw1394.transport.sansio.wire import NO_BOARD, MemberInfo

log = logging.getLogger("fw1394.host")
T = TypeVar("T")
#: Resets in a row a call rides out before it gives up with the last stale error.
_ATTEMPTS = 4


#: CSR offset of the configuration ROM: header, "1394", bus options, GUID high, GUID low.
CONFIG_ROM = 0xFFFF_F000_0400
_BUS_INFO_BYTES = 20
_BUS_NAME_1394 = 0x31333934


class BoardNotOnBusError(BusUnreachable, LookupError):
    """No member of the bus has that board ID (or GUID) now, or more than one has."""


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
    """Board ``board_id`` (a GUID for :class:`GuidPort`) is physical ID ``phy`` in
    ``generation`` (None: not on the bus)."""

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


def guid_of(bus_info: bytes) -> int | None:
    """The GUID in the first 20 bytes of a configuration ROM; None for a minimal ROM."""
    if len(bus_info) < _BUS_INFO_BYTES:
        return None
    header, name = int.from_bytes(bus_info[:4], "big"), int.from_bytes(bus_info[4:8], "big")
    if header >> 24 < 4 or name != _BUS_NAME_1394:
        return None  # info_length < 4: no bus information block with a GUID
    return int.from_bytes(bus_info[12:20], "big")


class BoardPort:
    """A :class:`~fw1394.host.port.Port` over ``port`` whose node numbers are board IDs."""

    #: How a key is named in messages and logs.
    KEY = "board ID"

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
            boards = ", ".join(self._name(b) for b in sorted(self._boards)) or "none"
            key = f"{self.KEY} {self._name(board_id)}"
            if phys:
                raise BoardNotOnBusError(
                    f"{key} is announced by {len(phys)} members (physical IDs "
                    f"{', '.join(map(str, phys))}) in generation {self._generation}"
                )
            raise BoardNotOnBusError(
                f"no board with {key} on the bus in generation "
                f"{self._generation} ({self.KEY}s: {boards})"
            )
        self._note(board_id, phys[0])
        return phys[0], self._generation

    def _refresh(self) -> None:
        generation, members = self.port.table()
        self._generation, self._boards = generation, self._index(generation, members)
        self.members = members

    def _index(self, generation: int, members: tuple[MemberInfo, ...]) -> dict[int, list[int]]:
        """Key -> the physical IDs that have it, in ``generation``."""
        return board_phys(members)

    def _name(self, key: int) -> str:
        return str(key)

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
                "%s %s: %s in generation %d (was %s in generation %d)",
                self.KEY,
                self._name(board_id),
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


class GuidPort(BoardPort):
    """A :class:`~fw1394.host.port.Port` over ``port`` whose node numbers are GUIDs."""

    KEY = "GUID"

    def __init__(self, port: PinnablePort) -> None:
        super().__init__(port)
        #: Member ID -> its GUID; a member keeps its ROM while on the bus. A member
        #: without one is asked again in the next generation (it may have been busy).
        self._guids: dict[int, int] = {}

    def _refresh(self) -> None:
        for attempt in range(_ATTEMPTS):
            try:
                super()._refresh()
                return
            except StaleGenerationError:
                # A reset while the ROMs were read: read the new generation's table.
                if attempt == _ATTEMPTS - 1:
                    raise

    def _index(self, generation: int, members: tuple[MemberInfo, ...]) -> dict[int, list[int]]:
        present = {member.member_id for member in members}
        self._guids = {m: g for m, g in self._guids.items() if m in present}
        found: dict[int, list[int]] = {}
        for phy, member in enumerate(members):
            if member.host:
                continue
            guid = self._guids.get(member.member_id)
            if guid is None:
                guid = self._read_guid(phy, generation)
                if guid is None:
                    continue
                self._guids[member.member_id] = guid
            found.setdefault(guid, []).append(phy)
        return found

    def _read_guid(self, phy: int, generation: int) -> int | None:
        try:
            rom = self.port.read_block(phy, CONFIG_ROM, _BUS_INFO_BYTES, generation=generation)
        except StaleGenerationError:
            raise
        except TransactionError:
            return None  # no ROM there (or it did not answer): no GUID
        return guid_of(rom)

    def _name(self, key: int) -> str:
        return f"{key:#018x}"


def _where(phy: int | None) -> str:
    return "not on the bus" if phy is None else f"physical ID {phy}"
