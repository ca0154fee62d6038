"""Which regime each half of a ratio ran in: how often its processes slept.

On a virtual machine a sleeping process takes about 20 µs to wake, so a
transaction between processes that poll costs half of one between processes
that sleep. Adaptive members (:mod:`fw1394.transport.media.idle`) poll or not
depending on what else is runnable, and where the scheduler puts the two ends
decides whether they poll on one CPU or on two: two rounds a few milliseconds
apart can run in different regimes, and the ratio of their medians then
compares the regimes, not the stacks.

So the bench counts, for each half (the raw ping-pong, the target), the
context switches of its own process and of the processes it talks to, per
call. A process that waits by polling has about 0 voluntary switches per
call, one that sleeps about 1; an involuntary switch (a preemption) means
another task wanted its CPU. Linux only: elsewhere the peers' counts are
unknown (None).
"""

from __future__ import annotations

import math
import resource
import time
from collections.abc import Sequence
from dataclasses import dataclass

from fw1394.transport.media.idle import IdleStrategy, default_idle

#: Two halves whose wake-ups or preemptions per call differ by more than this ran
#: in different regimes.
SAME_REGIME_SLACK = 0.25
#: A round switch waits this many polling windows, at least ``SETTLE_MIN_S`` and at
#: most ``SETTLE_MAX_S``.
SETTLE_WINDOWS = 4
SETTLE_MIN_S = 0.002
SETTLE_MAX_S = 0.1
_sleep = time.sleep


def settle_time(strategy: IdleStrategy) -> float:
    """How long a round switch waits for the half that just ran to stop polling.

    An adaptive process polls for its window after its last frame. A half that
    starts while the other half still polls sees more runnable tasks than
    cores, and its own adaptive members then sleep instead of polling until
    they next look (:func:`~fw1394.transport.media.idle.cores_enough`): the two
    halves of the ratio would run in different regimes because of the order
    they ran in. Members that always block or always poll have nothing to
    wait for.
    """
    if strategy.window == 0 or math.isinf(strategy.window):
        return 0.0
    return min(max(SETTLE_MIN_S, SETTLE_WINDOWS * strategy.window), SETTLE_MAX_S)


def settle(strategy: IdleStrategy | None = None) -> None:
    """Wait :func:`settle_time` of ``strategy`` (default: the run's, ``FW1394_IDLE``)."""
    wait = settle_time(strategy or default_idle())
    if wait:
        _sleep(wait)


@dataclass(frozen=True)
class Switches:
    """Context switches so far: this process's voluntary and involuntary ones, and
    the peers' voluntary ones (None when they cannot be read)."""

    own_voluntary: int
    own_involuntary: int
    peer_voluntary: int | None


def switches(peers: Sequence[int]) -> Switches:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    total: int | None = 0
    for pid in peers:
        count = _voluntary(pid)
        total = None if count is None or total is None else total + count
    return Switches(usage.ru_nvcsw, usage.ru_nivcsw, total)


def _voluntary(pid: int) -> int | None:
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("voluntary_ctxt_switches:"):
                    return int(line.split()[1])
    except (OSError, ValueError, IndexError):
        return None
    return None


@dataclass
class Regime:
    """The switches of one half of a run, summed over its rounds."""

    calls: int = 0
    wakeups: int = 0
    preemptions: int = 0
    #: The peers' wake-ups; None once a round could not read them.
    peer_wakeups: int | None = 0

    def add(self, before: Switches, after: Switches, calls: int) -> None:
        """Count a round of ``calls`` transactions between two snapshots."""
        self.calls += calls
        self.wakeups += after.own_voluntary - before.own_voluntary
        self.preemptions += after.own_involuntary - before.own_involuntary
        total, first, last = self.peer_wakeups, before.peer_voluntary, after.peer_voluntary
        if total is None or first is None or last is None:
            self.peer_wakeups = None
        else:
            self.peer_wakeups = total + last - first

    def per_call(self, count: int | None) -> float | None:
        if count is None or not self.calls:
            return None
        return round(count / self.calls, 2)

    def as_dict(self) -> dict[str, object]:
        return {
            "calls": self.calls,
            "wakeups_per_call": self.per_call(self.wakeups),
            "preemptions_per_call": self.per_call(self.preemptions),
            "peer_wakeups_per_call": self.per_call(self.peer_wakeups),
        }


def same_regime(one: Regime, other: Regime) -> bool:
    """Whether two halves waited alike: slept as often on this side and on the peers'
    (as far as known), and were preempted as often (the two ends of a round trip
    taking turns on one CPU instead of polling on two)."""
    pairs = (
        (one.per_call(one.wakeups), other.per_call(other.wakeups)),
        (one.per_call(one.peer_wakeups), other.per_call(other.peer_wakeups)),
        (one.per_call(one.preemptions), other.per_call(other.preemptions)),
    )
    return all(a is None or b is None or abs(a - b) <= SAME_REGIME_SLACK for a, b in pairs)
