"""A :class:`~fw1394.host.port.Port` that counts what it passes on, by request kind.

The kinds are named as the capture's dissector names request tcodes, so the
demo's own count and the one read back from its trace can be compared.
"""

from __future__ import annotations

from collections import Counter

from fw1394.host.port import Port


class CountingPort:
    """``port``, with every transaction counted in :attr:`counts` before it starts."""

    def __init__(self, port: Port) -> None:
        self._port = port
        self.counts: Counter[str] = Counter()

    def read_quadlet(self, node: int, offset: int) -> int:
        self.counts["read_quadlet_request"] += 1
        return self._port.read_quadlet(node, offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self.counts["write_quadlet_request"] += 1
        self._port.write_quadlet(node, offset, value)

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        self.counts["read_block_request"] += 1
        return self._port.read_block(node, offset, length)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self.counts["write_block_request"] += 1
        self._port.write_block(node, offset, data)
