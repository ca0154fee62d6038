"""The floor under every figure: a raw UDP ping-pong between two Python processes, same run.

An echo process on loopback answers each datagram; the bench times the
round trip. A 40-byte request answered by 40 bytes is the unit every
latency is divided by (the same exchange as ``bench/bus.py``'s baseline). A
40-byte request answered by 40 + 2048 bytes, about a 512-quadlet block read
response, is the unit of the largest block transfers. The difference
between the two is what the 2048 bytes themselves cost on loopback: next to
nothing, so a block transfer's slope measures the bus stack's own work per
byte.
"""

from __future__ import annotations

import os
import socket
import subprocess
import sys
from dataclasses import dataclass

from fw1394.experiments.summary import Summary, summarize
from fw1394.experiments.timing import TargetError, pin, time_calls
from fw1394.progress import Progress
from fw1394.transport.media.idle import Waiter, default_idle
from fw1394.transport.supervision.stop import stop

REQUEST_BYTES = 40
BLOCK_BYTES = 2048
RECEIVE_TIMEOUT_S = 1.0

# The echo answers a request with as many bytes as its first four ask for (0: the
# request itself), waits the way bus members do (FW1394_IDLE), and dies with the
# bench (PR_SET_PDEATHSIG) however the bench ends.
ECHO = """
import socket, sys
from fw1394.transport.media.idle import Waiter, default_idle
from fw1394.transport.supervision.procs import die_with_parent
die_with_parent(int(sys.argv[1]))
peer = ("127.0.0.1", int(sys.argv[2]))
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, (1).to_bytes(8, "little") + bytes(8))
print(s.getsockname()[1], flush=True)
wait = Waiter(s, default_idle(), 1.0).receive
replies = {}
while True:
    data = wait(65535)
    if data is None:
        continue
    if data == b"stop":
        break
    size = int.from_bytes(data[:4], "big")
    if size and size not in replies:
        replies[size] = bytes(size)
    s.sendto(replies[size] if size else data, peer)
"""


@dataclass(frozen=True)
class Baseline:
    """Round trips of the raw ping-pong, in microseconds."""

    small: list[float]
    block: list[float]
    failures: int

    @property
    def calls(self) -> int:
        """Round trips made for these samples, failed ones included (warm-ups not)."""
        return len(self.small) + len(self.block) + self.failures

    @property
    def unit_us(self) -> float:
        """The median small round trip: the ratio unit of the whole run."""
        return summarize(self.small).p50_us

    @property
    def block_unit_us(self) -> float:
        """The median round trip with a 2048-byte reply: the unit of 512-quadlet transfers."""
        return summarize(self.block).p50_us

    def as_dict(self) -> dict[str, object]:
        small: Summary = summarize(self.small)
        return {
            "request_bytes": REQUEST_BYTES,
            "round_trip": small.as_dict(),
            "block_reply_bytes": REQUEST_BYTES + BLOCK_BYTES,
            "block_round_trip": summarize(self.block).as_dict(),
            "block_extra_us": round(self.block_unit_us - self.unit_us, 2),
            # 2048 bytes per round trip, one at a time: what raw UDP moves like a block read.
            "block_mbit_s": round(BLOCK_BYTES * 8 / self.block_unit_us, 1),
            "failures": self.failures,
        }


class Echo:
    """The echo process and this side's socket, kept for a whole run.

    :meth:`round` times a number of round trips; a run alternates rounds of
    the baseline with rounds of the target, so that both halves of every ratio
    come from the same minutes of a shared machine.
    """

    def __init__(self, cpus: set[int] | None = None) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.echo = subprocess.Popen(
            [sys.executable, "-c", ECHO, str(os.getpid()), str(self.sock.getsockname()[1])],
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            text=True,
        )
        try:
            assert self.echo.stdout is not None
            self.peer = ("127.0.0.1", int(self.echo.stdout.readline()))
            if cpus is not None:
                pin([self.echo.pid], cpus)
            micros = int(RECEIVE_TIMEOUT_S * 1e6)
            timeval = (micros // 1_000_000).to_bytes(8, "little") + (micros % 1_000_000).to_bytes(
                8, "little"
            )
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, timeval)
            self._waiter = Waiter(self.sock, default_idle(), RECEIVE_TIMEOUT_S)
        except BaseException:
            self.close()
            raise
        self._small = bytes(REQUEST_BYTES)
        self._block = (REQUEST_BYTES + BLOCK_BYTES).to_bytes(4, "big") + bytes(REQUEST_BYTES - 4)

    def _exchange(self, request: bytes) -> None:
        self.sock.sendto(request, self.peer)
        self._waiter.traffic()
        if self._waiter.receive(65535) is None:
            raise TargetError("the echo did not answer within 1 s")

    def round(self, count: int, *, warmup: int = 0, progress: Progress | None = None) -> Baseline:
        """``count`` small and ``count // 4`` block-sized round trips."""
        small, lost = time_calls(
            lambda: self._exchange(self._small), count, warmup=warmup, progress=progress
        )
        block, lost_block = time_calls(lambda: self._exchange(self._block), max(count // 4, 10))
        return Baseline(small, block, lost + lost_block)

    def close(self) -> None:
        try:
            self.sock.sendto(b"stop", self.peer) if hasattr(self, "peer") else None
        finally:
            self.sock.close()
            stop_process(self.echo)


def merged(rounds: list[Baseline]) -> Baseline:
    """One baseline of several rounds' samples."""
    return Baseline(
        [s for r in rounds for s in r.small],
        [s for r in rounds for s in r.block],
        sum(r.failures for r in rounds),
    )


def measure(
    count: int, *, warmup: int, cpus: set[int] | None = None, progress: Progress | None = None
) -> Baseline:
    """``count`` small and ``count // 4`` block-sized round trips against a fresh echo process."""
    echo = Echo(cpus)
    try:
        if progress is not None:
            progress.start("raw UDP ping-pong", count)
        result = echo.round(count, warmup=warmup, progress=progress)
        if progress is not None:
            progress.finish(f"median {summarize(result.small).p50_us:.1f} us")
        return result
    finally:
        echo.close()


def stop_process(process: subprocess.Popen[str]) -> None:
    """Stop ``process`` and reap it; close its output pipe."""
    stop(process)
    if process.stdout is not None:
        process.stdout.close()
