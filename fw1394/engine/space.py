"""The address-space interface a node's responder serves.

A board emulator (or a plain memory) implements :class:`AddressSpace`. The
responder in :mod:`fw1394.engine` turns incoming request packets into calls on
it and turns the results (or the exceptions below) into acks and responses.
Nothing here knows about packets, sockets or clocks: time reaches a board only
through :meth:`AddressSpace.set_time`, in 49.152 MHz ticks, so tests control it.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

from fw1394.errors import TransactionError

#: The FPGA boards count time in ticks of their 49.152 MHz clock.
TICKS_PER_SECOND = 49_152_000


class SpaceError(TransactionError):
    """Base class of the errors an address space may raise."""


class AddressError(SpaceError):
    """No register at that offset (answered with ack/resp_address_error)."""


class DataError(SpaceError):
    """The request's length or data are not acceptable (resp_data_error)."""


class RequestTypeError(SpaceError):
    """The request type is not supported at that offset (ack/resp_type_error)."""


#: The former name of :class:`RequestTypeError`.
TypeError1394 = RequestTypeError


class BusyError(SpaceError):
    """The node cannot take the request now (answered with ack_busy_X)."""


@runtime_checkable
class AddressSpace(Protocol):
    """What a node exposes on the bus.

    ``offset`` is always the full 48-bit destination offset of the request;
    a board decides how many bits it decodes (the thesis and JHU boards use
    the low 16 bits as a quadlet index).
    """

    def read_quadlet(self, offset: int) -> int:
        """Value of the quadlet at ``offset`` (0..2**32-1)."""
        ...

    def write_quadlet(self, offset: int, value: int) -> None:
        """Store ``value``; raise a :class:`SpaceError` to refuse."""
        ...

    def read_block(self, offset: int, length: int) -> bytes:
        """``length`` bytes starting at ``offset`` (big-endian quadlets)."""
        ...

    def write_block(self, offset: int, data: bytes) -> None:
        """Store ``data`` (big-endian quadlets) starting at ``offset``."""
        ...

    def set_time(self, ticks: int) -> None:
        """Advance the board's clock to ``ticks`` (monotonic, 49.152 MHz)."""
        ...
