"""Every planted defect is found within its documented number of cases (docs/fuzzing.md).

In-process, seed 0, no shrinking: each campaign stops at the bound the
documentation promises, so a regression in the generator or the oracles that
makes a defect harder to find fails here.
"""

from __future__ import annotations

import pytest

from fw1394.boards.registry import BOARDS
from fw1394.engine.defects import PACKET_DEFECTS
from fw1394.fuzz.campaign import run
from fw1394.fuzz.settings import Settings

#: (board, defect, node policy and contract, cases allowed, oracles that may report it).
#: The bounds are the table of docs/fuzzing.md: the worst of 30 seeds, rounded up.
PLANTED = [
    ("memory", "bad-crc-read-answered", "thesis", 100, {"silence"}),
    ("memory", "bad-crc-write-performed", "thesis", 200, {"state", "reply"}),
    ("memory", "wedge-after-long-block-write", "thesis", 300, {"liveness", "reply"}),
    ("memory", "answers-other-node", "thesis", 100, {"silence"}),
    ("memory", "broadcast-read-answered", "thesis", 150, {"silence"}),
    ("memory", "source-id-from-request", "ieee1394", 600, {"reply"}),
    ("memory", "stale-tlabel", "thesis", 10, {"reply"}),
    ("memory", "truncated-write-stale", "thesis", 700, {"state", "reply"}),
    ("memory", "block-write-header-crc-unchecked", "thesis", 300, {"silence"}),
    ("memory", "crash-on-empty-block-write", "thesis", 700, {"process"}),
    ("qla1", "hw-version-swapped", "jhu", 10, {"reply"}),
    ("qla1", "rt-write-any-board", "jhu", 2000, {"state", "reply"}),
    ("qla1", "status-write-stored", "jhu", 700, {"state", "reply"}),
    ("qla1", "unmapped-address-error", "jhu", 100, {"state", "reply"}),
    ("qla1", "watchdog-disabled", "jhu", 7500, {"state", "reply"}),
    ("snake2010", "stale-read", "thesis", 400, {"state", "reply"}),
    ("snake2010", "write-ignores-mask", "thesis", 700, {"state", "reply"}),
]
#: A node on bus 1: a source ID copied from a request to the local-bus alias (0x3FF)
#: then differs from the node's own, which a node on bus 0x3FF never shows.
NODE_ON_BUS_1 = 0x0040


def campaign(kind: str, defects: tuple[str, ...], contract: str, cases: int) -> Settings:
    return Settings(
        f"inproc:{kind}",
        defects=defects,
        policy=contract,
        contract=contract,
        node_id=NODE_ON_BUS_1 if contract == "ieee1394" else 0xFFC0,
        max_cases=cases,
        seed=0,
        shrink_budget=0,
    )


def test_every_planted_defect_has_a_bound() -> None:
    listed = {(kind, defect) for kind, defect, *_ in PLANTED}
    expected = {("memory", d) for d in PACKET_DEFECTS}
    expected |= {(k, d) for k in ("qla1", "snake2010") for d in BOARDS[k].defects}
    assert listed == expected


@pytest.mark.parametrize(("kind", "defect", "contract", "bound", "oracles"), PLANTED)
def test_defect_is_found_within_its_bound(
    kind: str, defect: str, contract: str, bound: int, oracles: set[str]
) -> None:
    report = run(campaign(kind, (defect,), contract, bound))
    assert report.findings, f"{defect} not found in {bound} cases"
    first = min(report.findings, key=lambda finding: finding.case)
    assert first.oracle in oracles, (first.oracle, first.signature)


@pytest.mark.parametrize(("kind", "contract"), [("memory", "thesis"), ("qla1", "jhu")])
def test_a_clean_node_meets_its_own_contract(kind: str, contract: str) -> None:
    report = run(campaign(kind, (), contract, 3000))
    assert report.findings == []
    assert report.checks["silence"] > 500 and report.checks["state"] > 500


def test_snake2010_meets_the_thesis_contract() -> None:
    report = run(campaign("snake2010", (), "thesis", 2000))
    assert report.findings == []


def test_the_jhu_firmware_breaks_the_thesis_contract_as_documented() -> None:
    # jhu-eth1394.md §3.1: writes performed despite a bad CRC, block writes whose
    # header CRC is never checked, damaged packets acked instead of dropped.
    settings = Settings(
        "inproc:qla1", policy="jhu", contract="thesis", max_cases=2000, shrink_budget=0
    )
    signatures = {(f.oracle, f.signature) for f in run(settings).findings}
    assert ("silence", "bad-header-crc:write:ack_complete") in signatures
    assert any(o == "silence" and s.endswith("ack_data_error") for o, s in signatures)
    assert any(o == "state" and s.startswith("dropped-write") for o, s in signatures)
