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
  ``/proc/loadavg`` every 50 ms): when tasks wait for a core, polling only takes
  CPU from the process that is to answer. Two members polling for each other
  on two cores is the case the strategy exists for, so it counts as enough.
  An idle bus costs nothing; a busy one costs at most the window's CPU after
  each burst.

``FW1394_IDLE`` (``block``, ``spin``, ``adaptive`` or ``adaptive:MICROSECONDS``)
sets the strategy of every member started without an explicit one.
"""

from __future__ import annotations

import math
import os
import socket
import time
from collections.abc import Callable
from dataclasses import dataclass

ENVIRONMENT = "FW1394_IDLE"
#: How long an adaptive member keeps polling after traffic.
DEFAULT_WINDOW = 250e-6
_MSG_DONTWAIT = socket.MSG_DONTWAIT
#: How often an adaptive member looks whether every runnable task has a core.
CHECK_EVERY = 0.05
_LOADAVG = "/proc/loadavg"
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
        "_checked",
        "_cpus",
        "_enough",
        "_last",
        "_poll",
        "_recv",
        "_yield",
        "sock",
        "strategy",
        "window",
    )

    def __init__(self, sock: socket.socket, strategy: IdleStrategy, poll_interval: float) -> None:
        self.sock = sock
        self.strategy = strategy
        self.window = strategy.window
        self._poll = poll_interval
        self._recv = sock.recv
        self._yield: Callable[[], None] = getattr(os, "sched_yield", _no_yield)
        #: When this member last sent or received (monotonic seconds).
        self._last = -math.inf
        self._cpus = os.cpu_count() or 1
        #: Whether every runnable task had a core when last looked (at ``_checked``).
        self._enough = True
        self._checked = -math.inf

    def traffic(self) -> None:
        self._last = time.monotonic()

    def receive(self, size: int) -> bytes | None:
        """The next datagram (at most ``size`` bytes), or None when the wait ran out."""
        window = self.window
        if window:
            clock = time.monotonic
            now = clock()
            if window == math.inf:
                until = now + self._poll
            else:
                until = self._last + window
                if now < until and now - self._checked >= CHECK_EVERY:
                    self._checked = now
                    self._enough = cores_enough(self._cpus)
                if not self._enough:
                    until = now
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
                    self._last = clock()
                    return data
            if window == math.inf:
                return None
        try:
            data = self._recv(size)
        except (BlockingIOError, InterruptedError):
            return None
        if window:
            self._last = time.monotonic()
        return data


def cores_enough(cpus: int) -> bool:
    """Whether no more tasks are runnable than there are CPUs (this one included).

    The caller is itself runnable, so one CPU per runnable task means nobody
    waits: with ``<`` two members polling for each other on a two-CPU machine
    would each see the other and stop polling exactly when it pays.

    Linux's ``/proc/loadavg`` counts the runnable tasks right now (its fourth
    field, ``running/total``); elsewhere the answer is always yes.
    """
    try:
        with open(_LOADAVG, "rb") as file:
            running = int(file.read().split()[3].split(b"/")[0])
    except (OSError, ValueError, IndexError):
        return True
    return running <= cpus


def _no_yield() -> None:  # pragma: no cover - every POSIX system has sched_yield
    pass
