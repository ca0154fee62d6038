"""Blocking transactions over the bus: the host library's :class:`Port`, and locks."""

from __future__ import annotations

import functools
import time
from typing import Any

from fw1394.engine import LockCompleted, TransactionEvent, TransactionFailed
from fw1394.transport.bus_host import BusHost, StaleGenerationError, TransactionError
from fw1394.transport.express import Express
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import MemberInfo

__all__ = ["BusPort", "StaleGenerationError", "TransactionError", "open_bus"]


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

    ``generation`` pins a call to the bus generation ``node`` was chosen in
    (from :meth:`nodes` or :attr:`generation`): if the bus has reset since,
    the call raises :class:`StaleGenerationError` and sends nothing, since the
    physical ID may name another node now. Without it the call goes to
    whoever holds ``node`` when it is sent. :class:`fw1394.host.addressing.
    BoardPort` addresses boards by board ID and pins every call.
    """

    @functools.cached_property
    def _express(self) -> Express:
        return Express(self)

    def table(self) -> tuple[int, tuple[MemberInfo, ...]]:
        """The bus generation and its members in physical-ID order, once this host is ready.

        What the bus said since this host's last call is taken in first: a reset
        that happened meanwhile is in the answer.
        """
        self._come_back(time.monotonic())
        self.on_bus()
        return self.generation, self.members

    def read_quadlet(self, node: int, offset: int, *, generation: int | None = None) -> int:
        if generation is None:
            return self._express.read_quadlet(node, offset)
        with self.addressed_in(generation):
            return self._express.read_quadlet(node, offset)

    def write_quadlet(
        self, node: int, offset: int, value: int, *, generation: int | None = None
    ) -> None:
        if generation is None:
            self._express.write_quadlet(node, offset, value)
            return
        with self.addressed_in(generation):
            self._express.write_quadlet(node, offset, value)

    def read_block(
        self, node: int, offset: int, length: int, *, generation: int | None = None
    ) -> bytes:
        if generation is None:
            return self._express.read_block(node, offset, length)
        with self.addressed_in(generation):
            return self._express.read_block(node, offset, length)

    def write_block(
        self, node: int, offset: int, data: bytes, *, generation: int | None = None
    ) -> None:
        if generation is None:
            self._express.write_block(node, offset, data)
            return
        with self.addressed_in(generation):
            self._express.write_block(node, offset, data)

    def lock(
        self,
        node: int,
        offset: int,
        extended_tcode: int,
        argument: bytes,
        data: bytes,
        *,
        generation: int | None = None,
    ) -> bytes:
        """The old value at ``offset`` after a lock of kind ``extended_tcode``."""
        with self.addressed_in(generation):
            tid = self.start_lock(node, offset, extended_tcode, argument, data)
        event = _ended(self.wait(tid))
        assert isinstance(event, LockCompleted)
        return event.old_value


def open_bus(name: str = "default", **options: Any) -> BusPort:
    """Join bus ``name`` as a host: a :class:`BusPort`, closed by ``with`` or ``close()``.

    ``options`` are :class:`~fw1394.transport.bus_host.BusHost`'s (``ack_timeout``,
    ``split_timeout``, ``join_timeout``, ...). The bus must be running (``fw1394 bus
    up NAME``, or a :class:`~fw1394.transport.supervision.launch.LaunchedBus`); reads and
    writes raise :class:`fw1394.TransactionError` (:class:`fw1394.Timeout` when nothing
    answered).
    """
    return BusPort(BusConfig(name), **options)
