"""Blocking transactions over the bus: the host library's :class:`Port`, and locks."""

from __future__ import annotations

from fw1394.engine import LockCompleted, ReadCompleted, TransactionEvent, TransactionFailed
from fw1394.transport.bus_host import BusHost, TransactionError


def _ended(event: TransactionEvent) -> TransactionEvent:
    if isinstance(event, TransactionFailed):
        raise TransactionError(event)
    return event


class BusPort(BusHost):
    """A :class:`fw1394.host.port.Port` whose nodes are on a virtual bus.

    ``node`` is a physical ID (0-62, 63 broadcasts writes) or a full node ID.
    Failures raise :class:`TransactionError` naming the engine's reason.
    """

    def read_quadlet(self, node: int, offset: int) -> int:
        event = _ended(self.wait(self.start_read_quadlet(node, offset)))
        assert isinstance(event, ReadCompleted)
        return int.from_bytes(event.data, "big")

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        _ended(self.wait(self.start_write_quadlet(node, offset, value)))

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        event = _ended(self.wait(self.start_read_block(node, offset, length)))
        assert isinstance(event, ReadCompleted)
        return event.data

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        _ended(self.wait(self.start_write_block(node, offset, data)))

    def lock(
        self, node: int, offset: int, extended_tcode: int, argument: bytes, data: bytes
    ) -> bytes:
        """The old value at ``offset`` after a lock of kind ``extended_tcode``."""
        event = _ended(self.wait(self.start_lock(node, offset, extended_tcode, argument, data)))
        assert isinstance(event, LockCompleted)
        return event.old_value
