"""How a bus member waits for its next frame: block, spin, or spin briefly then block.

A transaction's latency on loopback is mostly wake-ups: every time a process
sleeps in ``recv`` the datagram that ends the sleep must wake it, and waking an
idle CPU of a virtual machine costs about as much as the rest of a quadlet
read. A member that polls its socket (non-blocking ``recv``) for a short while
after traffic is still awake when the answer comes, and the sender's
``sendto`` has no sleeper to wake either.

Strategies (``docs/performance.md`` gives their CPU cost):

* ``block``: sleep in ``recv`` until a frame comes or the poll interval passes.
  No CPU while idle; every frame is a wake-up.
* ``spin``: poll without sleeping, always (one core busy per member). For
  benchmarks on a machine with a core per member.
* ``adaptive`` (the default): poll for a window after the member last sent or
  received a frame (250 µs unless given: ``adaptive:100``), then block. Between
  polls the member yields its CPU (``sched_yield``), so that members sharing a
  core, such as four processes on two cores in ``fw1394 demo``, let the one with
  work run instead of starving it. And it polls only while every runnable task
  has a core (no more runnable tasks than CPUs, this one included, looked up in
  ``/proc/loadavg`` every 5 ms): when tasks wait for a core, polling only takes
  CPU from the process that is to answer, so a member stops polling within 5 ms
  of another task waiting for its CPU (the look is one ``pread`` of a file kept
  open, about 7 µs: 0.14 % of a polling member's CPU). Two members polling for each other
  on two cores is the case the strategy exists for, so it counts as enough.
  An idle bus costs nothing; a busy one costs at most the window's CPU after
  each burst. Only data frames count as traffic: a heartbeat or a beacon
  expects no answer, so it starts no polling.

  **More members than cores.** A bus with more members on this host than the
  machine has CPUs (``fw1394 demo``: a host, two nodes and the host adapter on
  two vCPUs) is *crowded* (:meth:`Waiter.share_host`, which the station calls
  at every bus reset): there an adaptive member never polls, because whenever
  two of them poll at once every other member that is woken waits for a core,
  and the load average, looked at every 5 ms, cannot see wake-ups that last
  tens of microseconds. Every frame is then a wake-up, as under ``block``.

A member that knows when its timers are next due (:attr:`Waiter.deadline`,
which a node sets) blocks until then when nothing comes, up to
:data:`LONGEST_SLEEP`, instead of waking every poll interval: an idle bus of
62 nodes otherwise spends half a CPU waking them to find nothing to do.

``FW1394_IDLE`` (``block``, ``spin``, ``adaptive`` or ``adaptive:MICROSECONDS``)
sets the strategy of every member started without an explicit one.
"""

from __future__ import annotations

import math
import os
import socket
import struct
import time
from collections.abc import Callable
from dataclasses import dataclass

ENVIRONMENT = "FW1394_IDLE"
#: How long an adaptive member keeps polling after traffic.
DEFAULT_WINDOW = 250e-6
_MSG_DONTWAIT = socket.MSG_DONTWAIT
#: How often an adaptive member looks whether every runnable task has a core:
#: the longest it may go on polling while another task waits for a CPU.
CHECK_EVERY = 0.005
#: The longest a member with a deadline blocks: how long a stopped node may
#: take to notice that it was told to stop.
LONGEST_SLEEP = 0.05
_LOADAVG = "/proc/loadavg"
#: ``/proc/loadavg``, opened once per process: a ``pread`` of it costs a sixth of
#: opening, reading and closing it (7 against 44 µs measured on two loaded cores).
_loadavg: int | None = None
_NAMES = ("block", "spin", "adaptive")


@dataclass(frozen=True, slots=True)
class IdleStrategy:
    """A way of waiting: poll for ``window`` seconds after traffic, then block.

    ``window`` 0 always blocks; ``math.inf`` never blocks.
    """

    name: str
    window: float

    def __str__(self) -> str:
        if self.name == "adaptive" and self.window != DEFAULT_WINDOW:
            return f"adaptive:{round(self.window * 1e6)}"
        return self.name


BLOCK = IdleStrategy("block", 0.0)
SPIN = IdleStrategy("spin", math.inf)
ADAPTIVE = IdleStrategy("adaptive", DEFAULT_WINDOW)


def parse_idle(text: str) -> IdleStrategy:
    """``block``, ``spin``, ``adaptive`` or ``adaptive:MICROSECONDS``; ValueError otherwise."""
    name, _, window = text.strip().lower().partition(":")
    if name not in _NAMES or (window and name != "adaptive"):
        raise ValueError(
            f"idle strategy {text!r}: expected block, spin, adaptive or adaptive:MICROSECONDS"
        )
    if name == "block":
        return BLOCK
    if name == "spin":
        return SPIN
    if not window:
        return ADAPTIVE
    try:
        micros = float(window)
    except ValueError:
        raise ValueError(f"idle strategy {text!r}: {window!r} is not a number") from None
    if not 0 <= micros <= 1e6:
        raise ValueError(f"idle strategy {text!r}: the window must be 0..1000000 us")
    return IdleStrategy("adaptive", micros / 1e6)


def default_idle() -> IdleStrategy:
    """The strategy ``FW1394_IDLE`` names, or adaptive when it is unset or empty."""
    text = os.environ.get(ENVIRONMENT, "")
    return parse_idle(text) if text else ADAPTIVE


class Waiter:
    """Receives datagrams from ``sock`` under ``strategy``.

    The socket's own receive timeout (``SO_RCVTIMEO``) bounds the blocking part;
    a spinning member gives up after ``poll_interval`` so its owner's timers run.
    Call :meth:`traffic` after sending: the answer to a frame is the traffic most
    worth being awake for.
    """

    __slots__ = (
        "_kind_at",
        "_last",
        "_poll",
        "_quiet_from",
        "_recv",
        "_timeout",
        "_yield",
        "deadline",
        "permit",
        "sock",
        "strategy",
        "window",
    )

    def __init__(
        self,
        sock: socket.socket,
        strategy: IdleStrategy,
        poll_interval: float,
        quiet_kinds: tuple[int, int] | None = None,
    ) -> None:
        """``quiet_kinds`` (offset, first): datagrams whose byte at ``offset`` is
        ``first`` or more are not traffic; None: every datagram is."""
        self.sock = sock
        self.strategy = strategy
        self.window = strategy.window
        self._poll = poll_interval
        self._recv = sock.recv
        self._yield: Callable[[], None] = getattr(os, "sched_yield", _no_yield)
        #: When this member last sent or received (monotonic seconds).
        self._last = -math.inf
        self.permit = PollPermit()
        self._kind_at, self._quiet_from = quiet_kinds or (0, 256)
        #: When the owner's timers are next due (monotonic); None: wake every poll interval.
        self.deadline: Callable[[], float] | None = None
        self._timeout = poll_interval

    def traffic(self) -> None:
        self._last = time.monotonic()

    def share_host(self, members: int) -> None:
        """This bus has ``members`` members on this host (this one included)."""
        self.permit.share_host(members)

    def receive(self, size: int) -> bytes | None:
        """The next datagram (at most ``size`` bytes), or None when the wait ran out."""
        window = self.window
        if window:
            clock = time.monotonic
            now = clock()
            if window == math.inf:
                until = now + self._poll
            else:
                until = self.permit.until(now, self._last + window)
            if now < until:
                recv, pause = self._recv, self._yield
                while True:
                    try:
                        data = recv(size, _MSG_DONTWAIT)
                    except (BlockingIOError, InterruptedError):
                        if clock() >= until:
                            break
                        pause()
                        continue
                    if self._is_traffic(data):
                        self._last = clock()
                    return data
            if window == math.inf:
                return None
        if self.deadline is not None:
            self._sleep_until(self.deadline())
        try:
            data = self._recv(size)
        except (BlockingIOError, InterruptedError):
            return None
        if window and self._is_traffic(data):
            self._last = time.monotonic()
        return data

    def _is_traffic(self, data: bytes) -> bool:
        at = self._kind_at
        return len(data) <= at or data[at] < self._quiet_from

    def _sleep_until(self, deadline: float) -> None:
        # The socket's receive timeout, set only when it must shrink (a timer is
        # due sooner than it would wake) or could double: a system call per change.
        wait = min(max(deadline - time.monotonic(), self._poll), LONGEST_SLEEP)
        if wait < self._timeout - self._poll or wait > 2 * self._timeout:
            set_receive_timeout(self.sock, wait)
            self._timeout = wait


def set_receive_timeout(sock: socket.socket, seconds: float) -> None:
    """Bound a blocking receive on ``sock`` (``SO_RCVTIMEO``): one system call per
    frame instead of ``select`` and ``recv``."""
    micros = max(1, int(seconds * 1e6))
    timeval = struct.pack("@ll", micros // 1_000_000, micros % 1_000_000)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, timeval)


class PollPermit:
    """Whether an adaptive member may go on polling (see the module): never on a
    crowded bus, and only while every runnable task has a core, looked up at
    most every :data:`CHECK_EVERY`."""

    __slots__ = ("_checked", "_cpus", "_enough", "crowded")

    def __init__(self) -> None:
        self._cpus = os.cpu_count() or 1
        #: Whether every runnable task had a core when last looked (at ``_checked``).
        self._enough = True
        self._checked = -math.inf
        #: More members of this bus on this host than CPUs: never poll.
        self.crowded = False

    def share_host(self, members: int) -> None:
        """This bus has ``members`` members on this host (this one included)."""
        self.crowded = crowded(members, self._cpus)

    def until(self, now: float, until: float) -> float:
        """``until`` when polling may go on until then, else ``now`` (block at once)."""
        if self.crowded:
            return now
        if now < until and now - self._checked >= CHECK_EVERY:
            self._checked = now
            self._enough = cores_enough(self._cpus)
        return until if self._enough else now


def crowded(members: int, cpus: int) -> bool:
    """Whether ``members`` processes of one bus on a machine of ``cpus`` CPUs must
    share cores, so that an adaptive member should not poll."""
    return members > cpus


def cores_enough(cpus: int) -> bool:
    """Whether no more tasks are runnable than there are CPUs (this one included).

    The caller is itself runnable, so one CPU per runnable task means nobody
    waits: with ``<`` two members polling for each other on a two-CPU machine
    would each see the other and stop polling exactly when it pays.

    Linux's ``/proc/loadavg`` counts the runnable tasks right now (its fourth
    field, ``running/total``); elsewhere the answer is always yes.
    """
    global _loadavg
    try:
        if _loadavg is None:
            _loadavg = os.open(_LOADAVG, os.O_RDONLY | os.O_CLOEXEC)
        running = int(os.pread(_loadavg, 64, 0).split()[3].split(b"/")[0])
    except (OSError, ValueError, IndexError):
        return True
    return running <= cpus


def _no_yield() -> None:  # pragma: no cover - every POSIX system has sched_yield
    pass
