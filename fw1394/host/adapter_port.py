"""A :class:`~fw1394.host.port.Port` through the bus's host adapter.

The adapter (:mod:`fw1394.transport.host_adapter.server`) is the bus's one host node;
an :class:`AdapterPort` is a program's handle on it, as a ``/dev/fw*`` file
is on a PC's link: opening and closing it causes no bus reset. Blocking
calls (:meth:`AdapterPort.read_quadlet` ...) make it a Port for
:class:`~fw1394.host.board.Board`; :meth:`AdapterPort.start` and
:meth:`AdapterPort.wait` keep several transactions outstanding at once.

Every request is pinned to a bus generation (``docs/host-adapter.md``): the
``generation`` given, or by default the port's :attr:`AdapterPort.generation`,
the one its latest reply reported. One addressed in a generation that has
ended raises :class:`StaleGenerationError` (nothing was sent); the port has
learnt the new generation by then, and the caller chooses its physical IDs
again (:class:`fw1394.host.addressing.BoardPort` does that by board ID).
"""

from __future__ import annotations

import itertools
import socket
from pathlib import Path
from typing import Self

from fw1394.engine import FailureReason, TransactionFailed
from fw1394.errors import BusUnreachable
from fw1394.transport.bus_host import StaleGenerationError, TransactionError
from fw1394.transport.host_adapter.protocol import (
    CHOSEN,
    NONE,
    STALE,
    VERSION,
    FrameBuffer,
    Op,
    Reply,
    Request,
    Status,
    hello,
    parse_reply,
)
from fw1394.transport.sansio.config import DEFAULT_BUS
from fw1394.transport.sansio.wire import NO_PHY, MemberInfo, parse_table
from fw1394.transport.supervision.runtime import adapter_socket, bus_dir


class AdapterError(BusUnreachable):
    """The adapter cannot be reached, or would not run a request."""


class NoAdapterError(AdapterError):
    """No adapter listens for this bus on this machine."""


class AdapterPort:
    """Transactions on bus ``name`` as its host adapter, shared with other programs.

    ``timeout`` bounds the wait for each reply (the adapter's own ack and
    split timeouts end a transaction long before it).
    """

    def __init__(
        self,
        name: str = DEFAULT_BUS,
        *,
        root: Path | None = None,
        path: Path | None = None,
        timeout: float = 10.0,
    ) -> None:
        self.name = name
        self.path = path or adapter_socket(bus_dir(name, root))
        self.timeout = timeout
        sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            sock.connect(str(self.path))
        except (FileNotFoundError, ConnectionRefusedError):
            sock.close()
            raise NoAdapterError(
                f"no host adapter for bus {name!r} on this machine (start the bus with "
                f"fw1394 bus up --name {name})"
            ) from None
        except OSError as error:
            sock.close()
            raise AdapterError(f"cannot open the adapter of bus {name!r}: {error}") from None
        sock.settimeout(timeout)
        self._sock = sock
        self._frames = FrameBuffer()
        self._numbers = itertools.count(1)
        self._replies: dict[int, Reply] = {}
        #: The bus generation and the adapter's physical ID, as of the last reply.
        self.generation = 0
        self.phy_id: int | None = None
        #: The protocol version agreed with the adapter.
        self.version = self._greet()

    def _greet(self) -> int:
        number = next(self._numbers)
        try:
            self._sock.sendall(hello(number).pack())
            reply = self.wait(number)
        except AdapterError as error:
            self._sock.close()
            raise AdapterError(
                f"the adapter of bus {self.name!r} does not speak protocol version {VERSION}: "
                f"{error}"
            ) from None
        version: int = CHOSEN.parse(reply.data).version
        return version

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        self._sock.close()

    # -- requests, outstanding at once --------------------------------------------------
    def start(
        self,
        op: Op,
        node: int = 0,
        offset: int = 0,
        *,
        generation: int | None = None,
        **fields: object,
    ) -> int:
        """Send a request addressed in ``generation`` (default: :attr:`generation`);
        its number for :meth:`wait`."""
        number = next(self._numbers) & 0xFFFFFFFF
        pinned = self.generation if generation is None else generation
        request = Request(
            number,
            op,
            node,
            offset,
            generation=pinned,
            **fields,  # type: ignore[arg-type]
        )
        try:
            self._sock.sendall(request.pack())
        except OSError as error:
            raise AdapterError(f"the adapter of bus {self.name!r} went away: {error}") from None
        return number

    def wait(self, number: int) -> Reply:
        """The reply to request ``number`` (replies to others are kept for their turn)."""
        while number not in self._replies:
            try:
                data = self._sock.recv(1 << 17)
            except TimeoutError:
                raise AdapterError(
                    f"no reply from the adapter of bus {self.name!r} in {self.timeout:g} s"
                ) from None
            except OSError as error:
                raise AdapterError(f"the adapter of bus {self.name!r}: {error}") from None
            if not data:
                raise AdapterError(f"the adapter of bus {self.name!r} closed the connection")
            for body in self._frames.feed(data):
                reply = parse_reply(body)
                self._replies[reply.request] = reply
        reply = self._replies.pop(number)
        self.generation = reply.generation
        self.phy_id = None if reply.phy == NO_PHY else reply.phy
        if reply.status is Status.refused:
            raise AdapterError(reply.detail)
        return reply

    def result(self, number: int) -> bytes:
        """The data of request ``number``'s reply; :class:`TransactionError` if it failed
        (:class:`StaleGenerationError` if it was addressed in a generation that ended)."""
        reply = self.wait(number)
        if reply.status is Status.failed:
            raise TransactionError(failure_of(reply))
        if reply.status is Status.stale:
            (addressed,) = STALE.unpack(reply.data[: STALE.size]) if reply.data else (0,)
            raise StaleGenerationError(addressed, reply.generation)
        return reply.data

    # -- the bus ------------------------------------------------------------------------
    def table(self) -> tuple[int, tuple[MemberInfo, ...]]:
        """The bus generation and its members in physical-ID order, as of one moment."""
        reply = self.wait(self.start(Op.info))
        _, members = parse_table(reply.data)
        return reply.generation, members

    def members(self) -> tuple[MemberInfo, ...]:
        """Every member of the bus in physical-ID order, the adapter among them."""
        return self.table()[1]

    def nodes(self) -> list[tuple[int, MemberInfo]]:
        """(physical ID, member) of every member but the adapter."""
        members = self.members()
        return [(phy, m) for phy, m in enumerate(members) if phy != self.phy_id]

    def send_packet(
        self, destination: int, packet: bytes, wait: float = 0.5, *, generation: int | None = None
    ) -> Reply:
        """Put ``packet`` on the bus as it is; the ack (``ack``) and response (``data``).

        Raises :class:`StaleGenerationError` if ``generation`` (default: the port's)
        has ended: the packet was not sent."""
        reply = self.wait(
            self.start(Op.send, destination, data=packet, wait=wait, generation=generation)
        )
        if reply.status is Status.stale:
            (addressed,) = STALE.unpack(reply.data[: STALE.size]) if reply.data else (0,)
            raise StaleGenerationError(addressed, reply.generation)
        return reply

    # -- the Port calls -----------------------------------------------------------------
    def read_quadlet(self, node: int, offset: int, *, generation: int | None = None) -> int:
        number = self.start(Op.read, node, offset, length=4, quadlet=True, generation=generation)
        return int.from_bytes(self.result(number), "big")

    def read_block(
        self, node: int, offset: int, length: int, *, generation: int | None = None
    ) -> bytes:
        return self.result(self.start(Op.read, node, offset, length=length, generation=generation))

    def write_quadlet(
        self, node: int, offset: int, value: int, *, generation: int | None = None
    ) -> None:
        data = value.to_bytes(4, "big")
        number = self.start(Op.write, node, offset, quadlet=True, data=data, generation=generation)
        self.result(number)

    def write_block(
        self, node: int, offset: int, data: bytes, *, generation: int | None = None
    ) -> None:
        self.result(self.start(Op.write, node, offset, data=data, generation=generation))

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
        number = self.start(
            Op.lock,
            node,
            offset,
            extended_tcode=extended_tcode,
            argument=argument,
            data=data,
            generation=generation,
        )
        return self.result(number)


def failure_of(reply: Reply) -> TransactionFailed:
    """The engine's failure event a failed reply stands for."""
    try:
        reason = FailureReason(reply.reason)
    except ValueError:
        reason = FailureReason.response_timeout
    rcode = None if reply.rcode == NONE else reply.rcode
    return TransactionFailed(
        reply.request,
        reason,
        rcode=rcode,
        detail=reply.detail,
        outcome_unknown=reply.outcome_unknown,
    )
