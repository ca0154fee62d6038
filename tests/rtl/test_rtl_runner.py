"""The harness's runner changes nothing but the speed: the same answers, judgements,
register accesses and cycle counts as the PHY model stepping every SCLK cycle.

Each design gets the same generated packets (mixed speeds, planted defects, one
batch whose packets cut a status transfer short) twice, in a simulation that
lets the runner drive the quiet cycles and in one that steps every cycle from
Python, and everything the simulator reports must be equal, cycle counts
included.
"""

from __future__ import annotations

import random
from pathlib import Path
from typing import Any

import pytest

from fw1394.fuzz.campaign import run
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.settings import Settings
from fw1394.rtl import simulation
from fw1394.rtl.defects import define
from fw1394.rtl.portmap import load
from fw1394.rtl.simulation import Simulation, missing_tools

HERE = Path(__file__).parent
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
DESIGNS = {
    "thesis": ("thesis", ()),
    "thesis-defects": (
        "thesis",
        ("long-hold", "long-write-hold", "no-closing-idle", "bad-crc-write", "early-ack"),
    ),
    "thesis-no-second-grant": ("thesis", ("no-second-grant",)),
    "thesis-own": ("thesis-own", ()),
    "plain-link": (str(HERE / "plain_link.toml"), ()),
    "split-flag": (str(HERE / "flag.toml"), ()),
    "late-release": (str(HERE / "late_release.toml"), ()),
    "slow-lreq": (str(HERE / "slow_lreq.toml"), ()),
    "self-write": (str(HERE / "self_write.toml"), ()),
}


def _simulated_run(
    spec: str, defects: tuple[str, ...], *, every_cycle: bool
) -> list[dict[str, Any]]:
    generator = Generator(0xFFC0, offset_model("snake2010"), random.Random(7))
    sim = Simulation(
        load(spec),
        physical_id=0,
        defines=tuple(define(name) for name in defects),
        every_cycle=every_cycle,
    )
    answers = []
    try:
        for batch in range(12):
            packets = [generator.case()[0] for _ in range(4)]
            speeds = [(batch + k) % 3 for k in range(4)]
            interrupting = 3 if batch == 5 else 0
            answers.append(
                sim.exchange(packets, batch * 1e-4, interrupting=interrupting, speeds=speeds)
            )
        sim.bus_reset(5)
        answers.append(sim.exchange([generator.case()[0]], 0.01))
        assert sim.restart()
        answers.append(sim.exchange([generator.case()[0]], 0.02))
    finally:
        sim.close()
    return answers


@pytest.mark.parametrize("design", DESIGNS)
def test_the_runner_answers_as_stepping_every_cycle_does(design: str) -> None:
    spec, defects = DESIGNS[design]
    fast = _simulated_run(spec, defects, every_cycle=False)
    stepped = _simulated_run(spec, defects, every_cycle=True)
    assert fast == stepped
    # The runs did something worth comparing: answers, and for the planted
    # defects, broken rules.
    assert any(ack is not None for answer in fast for ack, _, _ in answer["replies"])
    if defects:
        assert any(answer["violations"] for answer in fast)


def test_a_parked_simulation_serves_the_next_campaign_alike() -> None:
    # The second campaign runs on the first one's simulation, reset and checked
    # again, and finds the same as the first did on a fresh one.
    defects = ("no-second-grant", "bad-crc-write", "long-write-hold")
    settings = Settings("rtl:thesis", defects=defects, seed=5, max_cases=30, shrink_budget=0)
    fresh = run(settings)
    parked = list(simulation._PARKED)
    assert parked and parked[-1].alive()
    again = run(settings)
    assert parked == simulation._PARKED  # taken, used and given back: no new simulator
    assert sorted(f.key for f in again.findings) == sorted(f.key for f in fresh.findings)
    assert again.checks == fresh.checks and again.violations == fresh.violations
    assert {"no-grant:read", "hold:write"} <= {f.signature for f in fresh.findings}
