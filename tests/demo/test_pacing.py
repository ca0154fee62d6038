"""The demo's wait for the next cycle: on time, without spinning the way there.

A fake clock moves 1 µs per look and a fake sleep wakes a fixed 70 µs late (the
kernel's timer slack and a virtual machine's wake-up), or not late at all.
"""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.demo.pacing import MAX_MARGIN, Waker

LOOK = 1e-6


class FakeTime:
    def __init__(self, oversleep: float) -> None:
        self.now = 100.0
        self.oversleep = oversleep
        self.looks = 0
        self.slept: list[float] = []

    def clock(self) -> float:
        self.now += LOOK
        self.looks += 1
        return self.now

    def sleep(self, seconds: float) -> None:
        assert seconds > 0
        self.slept.append(seconds)
        self.now += seconds + self.oversleep


@pytest.mark.parametrize("oversleep", [0.0, 70e-6, 150e-6])
def test_after_a_few_cycles_each_wait_ends_on_time_and_mostly_asleep(oversleep: float) -> None:
    fake = FakeTime(oversleep)
    waker = Waker(fake.clock, fake.sleep)
    deadline = fake.now
    for cycle in range(60):
        deadline += 0.001
        fake.looks = 0
        woke = waker.wait_until(deadline)
        assert woke >= deadline, "never before the deadline"
        if cycle >= 40:
            # On time to a few looks, where sleeping to the deadline wakes a whole
            # oversleep late; and a few looks spent spinning, not the 200 of 0.2 ms.
            assert woke - deadline <= 3 * LOOK
            assert fake.looks <= 10
            assert waker.late == pytest.approx(oversleep, abs=3 * LOOK)


def test_a_sleep_late_beyond_the_margin_is_not_learned_past_it() -> None:
    # A machine so loaded that sleeps wake 5 ms late: spinning that long would
    # only make it worse, so the wait is cut short by at most the old spin.
    fake = FakeTime(0.005)
    waker = Waker(fake.clock, fake.sleep)
    deadline = fake.now
    for _ in range(100):
        deadline = max(deadline + 0.001, fake.now + 0.001)
        waker.wait_until(deadline)
    assert waker.late <= MAX_MARGIN
    assert min(fake.slept) >= 0.001 - MAX_MARGIN - 3 * LOOK


@settings(max_examples=100, deadline=None)
@given(st.lists(st.floats(0.0, 0.003), min_size=1, max_size=30), st.floats(0.0, 3e-4))
def test_never_returns_early(gaps: list[float], oversleep: float) -> None:
    fake = FakeTime(oversleep)
    waker = Waker(fake.clock, fake.sleep)
    for gap in gaps:
        moment = fake.now + gap
        assert waker.wait_until(moment) >= moment
