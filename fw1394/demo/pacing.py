"""Waiting for the next servo cycle without holding a core.

``time.sleep`` wakes late: the kernel's timer slack (50 µs by default) and the
wake-up itself, some 70 µs on a virtual machine, every sleep alike. Sleeping to
the deadline therefore starts every cycle that late; spinning the last stretch
instead, as the demo once did for 0.2 ms per cycle, takes a core from the nodes
and the capture, which on two cores are the processes the cycle waits for.
:class:`Waker` learns how late its sleeps wake, asks for that much less, and
spins only what is left, a few microseconds. :func:`tighten_timer_slack`
takes the slack itself away for the servo loop's process, so that what is
left to learn is the wake-up alone.
"""

from __future__ import annotations

import ctypes
import sys
import time
from collections.abc import Callable

#: The most a sleep is cut short by: what the demo spun per cycle before.
MAX_MARGIN = 0.0002
#: How fast the learned lateness follows the latest sleeps (a running mean over ~8).
FOLLOW = 1 / 8


#: prctl(2) option: how late the kernel may fire this thread's timers to batch them.
PR_SET_TIMERSLACK = 29
#: The slack asked for the servo loop (ns): the default 50 µs is a twentieth of a
#: 1 kHz period, and it varies from one wake-up to the next, which :class:`Waker`
#: can only cover by spinning.
SERVO_TIMER_SLACK_NS = 1000


def tighten_timer_slack(nanoseconds: int = SERVO_TIMER_SLACK_NS) -> bool:
    """Let the kernel fire this thread's timers at most ``nanoseconds`` late (Linux
    only; elsewhere nothing changes). Whether it took."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        libc = ctypes.CDLL(None, use_errno=True)
        return bool(libc.prctl(PR_SET_TIMERSLACK, nanoseconds, 0, 0, 0) == 0)
    except (OSError, AttributeError):
        return False


class Waker:
    """Sleeps until a moment of ``clock``, waking on time rather than late."""

    def __init__(
        self,
        clock: Callable[[], float] = time.perf_counter,
        sleep: Callable[[float], None] = time.sleep,
    ) -> None:
        self._clock = clock
        self._sleep = sleep
        #: How late a sleep wakes, learned (seconds).
        self.late = 0.0

    def wait_until(self, moment: float) -> float:
        """Return at ``moment`` or just after it; the time then."""
        clock = self._clock
        now = clock()
        wait = moment - now - self.late
        if wait > 0:
            self._sleep(wait)
            now = clock()
            overshoot = now - (moment - self.late)
            self.late += (min(max(overshoot, 0.0), MAX_MARGIN) - self.late) * FOLLOW
        while now < moment:
            now = clock()
        return now
