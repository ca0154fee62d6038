"""Blocking transactions over the bus: the host library's :class:`Port`, and locks."""

from __future__ import annotations

import functools

from fw1394.engine import LockCompleted, TransactionEvent, TransactionFailed
from fw1394.transport.bus_host import BusHost, TransactionError
from fw1394.transport.express import Express


def _ended(event: TransactionEvent) -> TransactionEvent:
    if isinstance(event, TransactionFailed):
        raise TransactionError(event)
    return event


class BusPort(BusHost):
    """A :class:`fw1394.host.port.Port` whose nodes are on a virtual bus.

    ``node`` is a physical ID (0-62, 63 broadcasts writes) or a full node ID.
    Failures raise :class:`TransactionError` naming the engine's reason. Reads
    and writes take the one-pass path of :mod:`fw1394.transport.express` when
    they can, the general one otherwise.
    """

    @functools.cached_property
    def _express(self) -> Express:
        return Express(self)

    def read_quadlet(self, node: int, offset: int) -> int:
        return self._express.read_quadlet(node, offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self._express.write_quadlet(node, offset, value)

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        return self._express.read_block(node, offset, length)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self._express.write_block(node, offset, data)

    def lock(
        self, node: int, offset: int, extended_tcode: int, argument: bytes, data: bytes
    ) -> bytes:
        """The old value at ``offset`` after a lock of kind ``extended_tcode``."""
        event = _ended(self.wait(self.start_lock(node, offset, extended_tcode, argument, data)))
        assert isinstance(event, LockCompleted)
        return event.old_value
