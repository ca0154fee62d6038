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
