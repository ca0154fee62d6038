"""A board model behind a link design's register bus.

A design that exposes its register bus (docs/rtl.md) gets its registers from
one of fw1394's board emulators, so the RTL answers with the very values
``inproc:BOARD`` would. The bus carries quadlets: a quadlet read or write
strobe with its register index, or the strobes of a block, one per quadlet,
with the block's byte length beside them. Blocks are handed to the board whole
(``read_block``/``write_block``), since boards treat blocks specially (the
snake2010 real-time block). A board error cannot travel back over such a bus:
a refused read gives zeros, a refused write does nothing.
"""

from __future__ import annotations

from contextlib import suppress

from fw1394.engine.space import TICKS_PER_SECOND, AddressSpace, SpaceError


class RegisterServer:
    """Serves register-bus strobes from ``space``; ``byte_addressed``: index * 4 is the offset."""

    def __init__(self, space: AddressSpace, *, byte_addressed: bool = False) -> None:
        self.space = space
        self.scale = 4 if byte_addressed else 1
        self._ticks = -1
        self._read: list[int] = []
        self._written: list[int] = []
        self._write_start = 0
        self._write_length = 0

    def set_time(self, now: float) -> None:
        """The fuzzer's time for the next packet (the board's clock only moves forward)."""
        ticks = int(now * TICKS_PER_SECOND)
        if ticks > self._ticks:
            self._ticks = ticks
            self.space.set_time(ticks)

    def new_packet(self) -> None:
        """A new request comes: a block left unfinished by the last one is given up."""
        self._read = []
        self._written = []

    def read(self, index: int) -> int:
        try:
            return self.space.read_quadlet(index * self.scale)
        except SpaceError:
            return 0

    def write(self, index: int, value: int) -> None:
        with suppress(SpaceError):
            self.space.write_quadlet(index * self.scale, value)

    def block_read(self, index: int, length: int) -> int:
        if not self._read:
            try:
                data = self.space.read_block(index * self.scale, length)
            except SpaceError:
                data = bytes(length)
            data = data.ljust(max(4, (length + 3) // 4 * 4), b"\0")
            self._read = [int.from_bytes(data[i : i + 4], "big") for i in range(0, len(data), 4)]
            self._read.reverse()
        return self._read.pop()

    def block_write(self, index: int, value: int, length: int) -> None:
        if not self._written:
            self._write_start, self._write_length = index, length
        self._written.append(value)
        if len(self._written) >= max(1, (self._write_length + 3) // 4):
            data = b"".join(v.to_bytes(4, "big") for v in self._written)[: self._write_length]
            self._written = []
            with suppress(SpaceError):
                self.space.write_block(self._write_start * self.scale, data)
