"""Each half's regime: context switches per call, their comparison, and the settle at a switch."""

from __future__ import annotations

import os
import subprocess
import sys
import time

import pytest

from fw1394.experiments import regime as regime_module
from fw1394.experiments.regime import (
    SETTLE_MAX_S,
    SETTLE_MIN_S,
    Regime,
    Switches,
    same_regime,
    settle,
    settle_time,
    switches,
)
from fw1394.transport.media.idle import ADAPTIVE, BLOCK, ENVIRONMENT, SPIN, parse_idle

LINUX = sys.platform.startswith("linux")


def test_settle_waits_a_few_windows_of_a_polling_member_and_nothing_otherwise() -> None:
    assert settle_time(BLOCK) == 0.0  # nobody polls
    assert settle_time(SPIN) == 0.0  # nobody ever stops polling
    assert settle_time(ADAPTIVE) == SETTLE_MIN_S  # 4 x 250 us is under the least
    assert settle_time(parse_idle("adaptive:1000")) == pytest.approx(0.004)
    assert settle_time(parse_idle("adaptive:1000000")) == SETTLE_MAX_S


def test_settle_sleeps_the_run_strategy_time(monkeypatch: pytest.MonkeyPatch) -> None:
    slept: list[float] = []
    monkeypatch.setattr(regime_module, "_sleep", slept.append)
    monkeypatch.setenv(ENVIRONMENT, "adaptive:2000")
    settle()
    monkeypatch.setenv(ENVIRONMENT, "block")
    settle()
    assert slept == [pytest.approx(0.008)]


def test_a_regime_sums_rounds_and_divides_by_calls() -> None:
    regime = Regime()
    regime.add(Switches(10, 5, 100), Switches(110, 5, 300), calls=100)
    regime.add(Switches(200, 7, 300), Switches(200, 57, 300), calls=100)
    assert regime.as_dict() == {
        "calls": 200,
        "wakeups_per_call": 0.5,
        "preemptions_per_call": 0.25,
        "peer_wakeups_per_call": 1.0,
    }


def test_peers_unknown_once_stay_unknown() -> None:
    regime = Regime()
    regime.add(Switches(0, 0, 10), Switches(5, 0, 20), calls=10)
    regime.add(Switches(0, 0, None), Switches(5, 0, 30), calls=10)
    regime.add(Switches(0, 0, 30), Switches(5, 0, 40), calls=10)
    assert regime.peer_wakeups is None
    assert regime.as_dict()["peer_wakeups_per_call"] is None
    assert Regime().as_dict()["wakeups_per_call"] is None  # no calls: no ratio


def _regime(wakeups: int, peers: int | None, preemptions: int, calls: int = 100) -> Regime:
    return Regime(calls, wakeups, preemptions, peers)


def test_halves_differ_when_one_slept_or_shared_a_cpu() -> None:
    polling = _regime(0, 0, 0)
    assert same_regime(polling, _regime(10, 20, 5))  # within the slack
    assert not same_regime(polling, _regime(100, 0, 0))  # this side slept
    assert not same_regime(polling, _regime(0, 100, 0))  # the peer slept
    assert not same_regime(polling, _regime(0, 0, 80))  # both ends on one CPU
    assert same_regime(polling, _regime(0, None, 0))  # unknown peers are not held against it
    assert same_regime(_regime(100, 100, 0), _regime(98, 101, 1))  # both slept: alike


@pytest.mark.skipif(not LINUX, reason="context switch counts come from Linux's /proc")
@pytest.mark.process
def test_switches_count_sleeps_here_and_in_a_peer() -> None:
    child = subprocess.Popen(
        [
            sys.executable,
            "-c",
            "import sys, time\nsys.stdin.readline()\n"
            "for _ in range(20): time.sleep(0.001)\nsys.stdin.readline()",
        ],
        stdin=subprocess.PIPE,
        text=True,
    )
    assert child.stdin is not None
    try:
        time.sleep(0.2)
        before = switches([child.pid])
        for _ in range(5):
            time.sleep(0.001)
        child.stdin.write("go\n")
        child.stdin.flush()
        time.sleep(0.3)  # its 20 sleeps are over; it waits for the next line
        after = switches([child.pid])
    finally:
        child.communicate("done\n", timeout=10)
    assert after.own_voluntary - before.own_voluntary >= 5
    assert before.peer_voluntary is not None and after.peer_voluntary is not None
    assert after.peer_voluntary - before.peer_voluntary >= 20
    assert switches([child.pid]).peer_voluntary is None  # gone: unknown, not zero
    assert switches([]).peer_voluntary == 0
    assert switches([os.getpid()]).peer_voluntary is not None
