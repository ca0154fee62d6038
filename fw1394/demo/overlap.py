"""The servo cycle's block writes to different boards, overlapped on the bus.

A cycle reads every board, computes, and writes every board. Through the
blocking :class:`~fw1394.host.port.Port` calls each write waits for its ack
before the next board's goes out, so the boards take them one after the other
and the host sleeps and wakes once per write. A write needs no answer before
the next board's write: inside :meth:`OverlappingPort.cycle` block writes go
without waiting for their acks, the cycle ends when every one of them has
ended, and the first failure is raised then. The boards then take their
writes at the same time, on two cores, and one wake-up of the host can take
both acks.

The reads stay one at a time: a board answers a block read in the same bus
tenure as its ack (a concatenated response, thesis section 6.1), so on a cable
nothing comes between the request and the response, and a capture of the
demo shows exactly that; a second board's request in between would make the
read look split.

Outside a cycle, and for anything but block writes, every call is the plain
blocking one, after whatever the cycle had outstanding has ended: the power
request a board sends after its block write still reaches the board after it.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from fw1394.engine import TransactionFailed
from fw1394.host.bus_port import BusPort
from fw1394.transport.bus_host import TransactionError


class OverlappingPort:
    """``port``'s calls, with a cycle's block writes overlapped."""

    def __init__(self, port: BusPort) -> None:
        self._port = port
        self._writes: list[int] = []
        self._posting = False

    @contextmanager
    def cycle(self) -> Iterator[None]:
        """Inside, block writes do not wait for their acks; at the end every one
        has ended (raises the first that failed)."""
        self.settle()
        try:
            self._posting = True
            yield
        except BaseException:
            # The error raised is the cycle's; what else was outstanding ends unseen.
            self._posting = False
            self._end_outstanding()
            raise
        self._posting = False
        self.settle()

    def settle(self) -> None:
        """Wait for every transaction still outstanding; raise the first failure."""
        failure = self._end_outstanding()
        if failure is not None:
            raise TransactionError(failure)

    def _end_outstanding(self) -> TransactionFailed | None:
        outstanding, self._writes = self._writes, []
        failure: TransactionFailed | None = None
        for tid in outstanding:
            event = self._port.wait(tid)
            if isinstance(event, TransactionFailed) and failure is None:
                failure = event
        return failure

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        self.settle()
        return self._port.read_block(node, offset, length)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        if self._posting:
            self._writes.append(self._port.start_write_block(node, offset, data))
            return
        self.settle()
        self._port.write_block(node, offset, data)

    def read_quadlet(self, node: int, offset: int) -> int:
        self.settle()
        return self._port.read_quadlet(node, offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self.settle()
        self._port.write_quadlet(node, offset, value)
