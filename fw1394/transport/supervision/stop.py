"""Stopping processes: ask, wait a grace period, then SIGKILL, and always reap.

Every place that ends a child process (a bus's supervisor and its nodes, a
launched bus, a capture, a simulator, a benchmark's echo server) stops it
here, so a process that ignores the request, one that already exited and one
that hangs in its shutdown all end the same bounded way and none is left a
zombie. The request is SIGTERM unless the process has a cleaner stop of its
own (a capture finishes its file on SIGINT; a simulator is told "close" on its
socket, and then nothing more is sent before the grace period runs out).
"""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, Protocol

from fw1394.transport.supervision.procs import process_alive

GRACE = 5.0
"""Seconds a process gets to end by itself: a node leaving the bus says goodbye
within one lease, well under this even on a loaded two-core machine."""

_POLL_FIRST, _POLL_MOST = 0.001, 0.02


class Stoppable(Protocol):
    """What :func:`stop` needs of a process (:class:`subprocess.Popen` is one)."""

    @property
    def pid(self) -> int: ...

    def poll(self) -> int | None: ...

    def send_signal(self, sig: int) -> None: ...


@dataclass(frozen=True)
class Pid:
    """A process of this host that is not our child (a member another program started).

    ``alive`` decides whether ``pid`` is still the process meant: a pid that
    was recycled for another program must never be signalled.
    """

    pid: int
    alive: Callable[[int], bool] = process_alive

    def poll(self) -> int | None:
        return None if self.alive(self.pid) else 0

    def send_signal(self, sig: int) -> None:
        os.kill(self.pid, sig)  # stop() polls (so checks ``alive``) just before


@dataclass
class Stopped:
    """How a :func:`stop` went: which pids needed SIGKILL, which could not be stopped."""

    killed: list[int] = field(default_factory=list)
    left: list[int] = field(default_factory=list)


def stop(
    processes: Stoppable | Iterable[Stoppable],
    grace: float = GRACE,
    *,
    ask: int | None = signal.SIGTERM,
) -> Stopped:
    """End ``processes``: send ``ask`` (None: they were already asked some other way),
    give them ``grace`` seconds together, then SIGKILL what is left and reap it.

    Processes that already exited are only reaped. A process that cannot be
    signalled (another user's) or that outlives SIGKILL by another ``grace``
    (stuck in the kernel) is reported in :attr:`Stopped.left`, never waited
    for without bound.
    """
    group = list(processes) if isinstance(processes, Iterable) else [processes]
    outcome = Stopped()
    running = [p for p in group if p.poll() is None]
    if ask is not None:
        running = [p for p in running if _signal(p, ask, outcome)]
    running = _wait(running, grace)
    for process in running:
        if _signal(process, signal.SIGKILL, outcome):
            outcome.killed.append(process.pid)
    outcome.left += [p.pid for p in _wait([p for p in running if p.pid not in outcome.left], grace)]
    return outcome


def _signal(process: Stoppable, sig: int, outcome: Stopped) -> bool:
    """Send ``sig``; False (and ``left``) when the process may not be signalled."""
    try:
        process.send_signal(sig)
    except ProcessLookupError:
        pass  # it ended between the poll and the signal; the next poll reaps it
    except PermissionError:
        outcome.left.append(process.pid)
        return False
    return True


def _wait(processes: list[Any], seconds: float) -> list[Any]:
    """Poll (and so reap) until every process ended or ``seconds`` passed; those still running."""
    limit = time.monotonic() + seconds
    pause = _POLL_FIRST
    while True:
        processes = [p for p in processes if p.poll() is None]
        if not processes or time.monotonic() >= limit:
            return processes
        time.sleep(min(pause, max(0.0, limit - time.monotonic())))
        pause = min(pause * 2, _POLL_MOST)
