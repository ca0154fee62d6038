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

from fw1394.experiments.phase_progress import Progress
from fw1394.experiments.summary import Summary, summarize
from fw1394.experiments.timing import TargetError, pin, time_calls

REQUEST_BYTES = 40
BLOCK_BYTES = 2048
RECEIVE_TIMEOUT_S = 1.0

# The echo answers a request with as many bytes as its first four ask for (0: the
# request itself), and dies with the bench (PR_SET_PDEATHSIG) however the bench ends.
ECHO = """
import socket, sys
from fw1394.transport.procs import die_with_parent
die_with_parent(int(sys.argv[1]))
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
print(s.getsockname()[1], flush=True)
replies = {}
while True:
    data, peer = s.recvfrom(65535)
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


def measure(
    count: int, *, warmup: int, cpus: set[int] | None = None, progress: Progress | None = None
) -> Baseline:
    """``count`` small and ``count // 4`` block-sized round trips against a fresh echo process."""
    echo = subprocess.Popen(
        [sys.executable, "-c", ECHO, str(os.getpid())],
        stdin=subprocess.DEVNULL,
        stdout=subprocess.PIPE,
        text=True,
    )
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        assert echo.stdout is not None
        peer = ("127.0.0.1", int(echo.stdout.readline()))
        if cpus is not None:
            pin([echo.pid], cpus)
        sock.bind(("127.0.0.1", 0))
        sock.settimeout(RECEIVE_TIMEOUT_S)
        small_request = bytes(REQUEST_BYTES)
        block_request = (REQUEST_BYTES + BLOCK_BYTES).to_bytes(4, "big") + bytes(REQUEST_BYTES - 4)

        def exchange(request: bytes) -> None:
            sock.sendto(request, peer)
            try:
                sock.recv(65535)
            except TimeoutError:
                raise TargetError("the echo did not answer within 1 s") from None

        if progress is not None:
            progress.start("raw UDP ping-pong", count)
        small, lost = time_calls(
            lambda: exchange(small_request), count, warmup=warmup, progress=progress
        )
        block, lost_block = time_calls(lambda: exchange(block_request), max(count // 4, 10))
        if progress is not None:
            progress.finish(f"median {summarize(small).p50_us:.1f} us")
        sock.sendto(b"stop", peer)
        return Baseline(small, block, lost + lost_block)
    finally:
        sock.close()
        _stop(echo)


def _stop(process: subprocess.Popen[str]) -> None:
    try:
        process.wait(2.0)
    except subprocess.TimeoutExpired:
        process.kill()
        process.wait()
    if process.stdout is not None:
        process.stdout.close()
