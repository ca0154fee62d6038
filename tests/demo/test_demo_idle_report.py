"""The demo's report names how its members waited: strategy, medium, and crowding."""

from __future__ import annotations

import pytest

from fw1394.demo.report import summary
from fw1394.demo.run import DemoResult


@pytest.mark.parametrize(
    ("members", "cpus", "crowded"), [(4, 2, True), (2, 2, False), (4, 8, False)]
)
def test_the_report_says_whether_members_outnumbered_the_cpus(
    members: int, cpus: int, crowded: bool
) -> None:
    result = DemoResult(idle="adaptive", medium="udp", members_here=members, cpus=cpus)
    assert summary(result)["idle"] == {
        "strategy": "adaptive",
        "medium": "udp",
        "members_here": members,
        "cpus": cpus,
        "crowded": crowded,
    }


def test_the_report_sums_the_processes_into_the_goal_figures() -> None:
    # 150 µs of CPU per cycle at 1000 cycles a second is 0.15 CPUs; 3 late of 1000.
    result = DemoResult(cycles=1000, seconds=1.0, overruns=3)
    result.processes = {
        "host": {"cpu_us": 100.0, "wakeups": 3.0, "preemptions": 0.0},
        "capture": {"cpu_us": 50.0, "wakeups": 0.2, "preemptions": 0.0},
    }
    numbers = summary(result)
    assert numbers["cpu_us_per_cycle"] == 150.0
    assert numbers["cpus_busy"] == 0.15
    assert numbers["overrun_percent"] == 0.3
