"""``rtl:`` as a fuzz target: the campaign, the differential check, planted defects.

The thesis RTL with its register bus served by the snake2010 emulator must
agree with ``inproc:snake2010`` on every answer; each planted RTL defect must
be found by a short seeded campaign (the bounds are those in docs/fuzzing.md).
"""

from __future__ import annotations

from fnmatch import fnmatch

import pytest

from fw1394.fuzz.campaign import run
from fw1394.fuzz.rtl_differential import compare
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.fuzz.targets import check, target_kind
from fw1394.rtl.simulation import missing_tools

pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]


def test_settings_for_rtl_targets() -> None:
    assert target_kind(Settings("rtl:thesis")) == "snake2010"
    assert target_kind(Settings("rtl:thesis-own")) is None
    check(Settings("rtl:thesis", defects=("early-ack", "stale-read")))
    with pytest.raises(SettingsError, match="unknown defect 'wedge'"):
        check(Settings("rtl:thesis", defects=("wedge",)))
    with pytest.raises(SettingsError, match=r"does not exist|No such file"):
        check(Settings("rtl:nowhere.toml"))
    with pytest.raises(SettingsError, match="the only option is waves=FILE"):
        check(Settings("rtl:thesis,colour=red"))


def test_emulator_and_rtl_agree_case_by_case() -> None:
    assert list(compare(100, seed=3)) == []


def test_a_disagreement_names_both_answers() -> None:
    found = list(compare(40, seed=0, defects=frozenset({"any-node"})))
    assert found
    first = found[0]
    assert first.emulator == "silence" and first.rtl.startswith("ack_")


def test_campaign_on_the_thesis_rtl_is_clean() -> None:
    report = run(Settings("rtl:thesis", max_cases=60, seed=1, shrink_budget=0))
    assert report.findings == []
    assert report.cases == 60


@pytest.mark.parametrize(
    ("defect", "cases", "finding"),
    [
        ("no-header-crc", 10, ("silence", "bad-header-crc:*")),
        ("any-node", 20, ("silence", "other-node:*")),
        # (a mismatch names the register it happened at: read@NAME:rcode)
        ("unbounded-block", 80, ("reply", "read*:rcode")),
        ("early-ack", 80, ("silence", "bad-length:write:ack_complete")),
        ("long-hold", 5, ("interface", "hold:read")),
        ("long-write-hold", 20, ("interface", "hold:write")),
        ("no-second-grant", 5, ("interface", "no-grant:read")),
        ("no-closing-idle", 5, ("interface", "closing-idle:*")),
    ],
)
def test_planted_rtl_defects_are_found(defect: str, cases: int, finding: tuple[str, str]) -> None:
    report = run(Settings("rtl:thesis", defects=(defect,), max_cases=cases, shrink_budget=0))
    oracle, pattern = finding
    assert any(f.oracle == oracle and fnmatch(f.signature, pattern) for f in report.findings), [
        (f.oracle, f.signature) for f in report.findings
    ]


def test_one_rule_broken_on_two_paths_is_two_findings() -> None:
    # Both defects break the same rule (Hold beyond 47 cycles), one before a read's
    # response, one before a write's ack: two root causes, two findings.
    defects = ("long-hold", "long-write-hold")
    report = run(Settings("rtl:thesis", defects=defects, max_cases=12, seed=2, shrink_budget=6))
    holds = {f.signature: f for f in report.findings if f.oracle == "interface"}
    assert {"hold:read", "hold:write"} <= set(holds), sorted(holds)
    # The write's finding replays, shrunk to a packet of its own kind (tcode 0 or 1).
    write = holds["hold:write"]
    assert write.reproduced
    assert write.packet[3] >> 4 in (0, 1)
