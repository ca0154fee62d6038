"""A node that is nothing but memory: the plainest :class:`AddressSpace`.

Two ways to read an offset:

* byte addressing (the IEEE 1394 way, the default): offset ``base + n`` is byte
  ``n``; a quadlet access must be quadlet-aligned; a block may start and end
  anywhere inside the memory;
* quadlet-index addressing (the thesis and JHU boards): offset ``base + n`` is
  quadlet ``n``, and a block of ``L`` bytes covers ``L / 4`` consecutive indices.

``mask`` keeps only the offset bits the node decodes (the JHU boards decode bits
15..0 and alias everything above). Offsets outside the memory raise
:class:`AddressError`, as does a misaligned quadlet access.
"""

from __future__ import annotations

from fw1394.engine.space import AddressError, DataError

_QUADLET = 4
_ALL_OFFSET_BITS = (1 << 48) - 1


class MemorySpace:
    """``size`` bytes of memory served at ``base``, initially ``contents`` then zeros.

    ``board_id`` and ``defects`` make it a board factory like the others in
    :mod:`fw1394.boards`; plain memory has no planted defects.
    """

    def __init__(
        self,
        size: int = 4096,
        *,
        base: int = 0,
        quadlet_index: bool = False,
        mask: int = _ALL_OFFSET_BITS,
        contents: bytes = b"",
        board_id: int = 0,
        defects: frozenset[str] = frozenset(),
    ) -> None:
        if size < 0 or size % _QUADLET:
            raise ValueError(f"size {size} is not a whole number of quadlets")
        if len(contents) > size:
            raise ValueError(f"{len(contents)} bytes of contents do not fit {size}")
        if defects:
            raise ValueError(f"plain memory has no defects to plant: {sorted(defects)}")
        self._memory = bytearray(contents) + bytearray(size - len(contents))
        self.base = base
        self.quadlet_index = quadlet_index
        self.mask = mask
        self.board_id = board_id
        #: The last time the node was given, in 49.152 MHz ticks.
        self.ticks = 0

    # -- the AddressSpace protocol -----------------------------------------------------
    def read_quadlet(self, offset: int) -> int:
        start = self._start(offset, _QUADLET, quadlet=True)
        return int.from_bytes(self._memory[start : start + _QUADLET], "big")

    def write_quadlet(self, offset: int, value: int) -> None:
        start = self._start(offset, _QUADLET, quadlet=True)
        self._memory[start : start + _QUADLET] = value.to_bytes(_QUADLET, "big")

    def read_block(self, offset: int, length: int) -> bytes:
        start = self._start(offset, length, quadlet=False)
        return bytes(self._memory[start : start + length])

    def write_block(self, offset: int, data: bytes) -> None:
        start = self._start(offset, len(data), quadlet=False)
        self._memory[start : start + len(data)] = data

    def set_time(self, ticks: int) -> None:
        self.ticks = ticks

    # -- for tests and tools -----------------------------------------------------------
    @property
    def size(self) -> int:
        return len(self._memory)

    def contents(self) -> bytes:
        """A copy of the whole memory."""
        return bytes(self._memory)

    def _start(self, offset: int, length: int, *, quadlet: bool) -> int:
        """Index into the memory of an access of ``length`` bytes at ``offset``."""
        relative = (offset & self.mask) - self.base
        if self.quadlet_index:
            if length % _QUADLET:
                raise DataError(f"{length} bytes is not a whole number of quadlets")
            start = relative * _QUADLET
        else:
            if quadlet and relative % _QUADLET:
                raise AddressError(f"quadlet access at {offset:#x} is not quadlet-aligned")
            start = relative
        if start < 0 or start + length > len(self._memory):
            raise AddressError(f"{length} bytes at {offset:#x} are outside the memory")
        return start
