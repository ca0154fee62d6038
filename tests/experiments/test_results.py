"""The JSON of ``fw1394 bench``: its keys stay, the block figures divide by their own raw rounds."""

from __future__ import annotations

import numpy as np
import pytest

from fw1394.experiments.baseline import Baseline
from fw1394.experiments.measurements import BlockRun, QuadletRun
from fw1394.experiments.regime import Regime
from fw1394.experiments.report_text import render
from fw1394.experiments.results import digest
from fw1394.experiments.run import BenchResult
from fw1394.experiments.run_settings import QUICK

#: Keys a block fit had before the robust line; readers of old runs' JSON rely on them.
FIT_KEYS = {"base_us", "slope_us_per_quadlet", "mbit_s", "r_squared", "points", "x_base"}
SIZE_KEYS = {"median_us", "p50_512_us", "x_512"}
SPREAD_KEYS = {"residual_iqr_us", "samples_per_size", "sample_iqr_us"}


def synthetic_run() -> BenchResult:
    rng = np.random.default_rng(3)
    sizes = list(QUICK.block_sizes)

    def times(base: float) -> dict[int, list[float]]:
        return {s: list(base + 0.01 * s + rng.normal(0, 1.0, QUICK.block_passes)) for s in sizes}

    quadlet_floor = Baseline([20.0] * 100, [22.0] * 25, 0)
    block_floor = Baseline([10.0] * 100, [12.0] * 25, 0)
    return BenchResult(
        QUICK,
        {"kind": "virtual-bus", "node": 0, "board": "snake2010"},
        {"cpus": 2, "python": "3.11", "pinned": False, "load_average_before": [1.0]},
        Baseline(quadlet_floor.small + block_floor.small, quadlet_floor.block, 0),
        QuadletRun(list(rng.normal(30, 1, 500)), list(rng.normal(20, 1, 500)), 0),
        BlockRun(sizes, QUICK.block_passes, times(40.0), times(30.0)),
        block_baseline=block_floor,
    )


def test_block_keys_are_kept_and_the_new_ones_added() -> None:
    block = digest(synthetic_run())["block"]
    assert {"sizes", "passes", "failures"} <= set(block)
    assert block["fit"] == "theil-sen line through the median of each size"
    assert (block["raw_round_trip_p50_us"], block["raw_block_round_trip_p50_us"]) == (10.0, 12.0)
    for name, base in (("read", 40.0), ("write", 30.0)):
        fit = block[name]
        assert set(fit) >= FIT_KEYS | SIZE_KEYS | SPREAD_KEYS
        assert fit["base_us"] == pytest.approx(base, abs=1.0)
        assert fit["samples_per_size"] == QUICK.block_passes
        assert 0.5 < fit["sample_iqr_us"] < 2.5  # a normal sample's IQR is 1.35 sigma
        # The block unit is the rounds interleaved with the block passes, not the run's.
        assert fit["x_base"] == pytest.approx(fit["base_us"] / 10.0, abs=0.01)
        assert fit["x_512"] == pytest.approx(fit["p50_512_us"] / 12.0, abs=0.01)


def test_the_block_servo_cycle_has_the_block_unit_and_the_text_names_it() -> None:
    numbers = digest(synthetic_run())
    servo = numbers["servo"]
    assert servo["block"]["x_cycle"] == pytest.approx(servo["block"]["cycle_us"] / 10.0, abs=0.01)
    assert servo["quadlet"]["x_cycle"] == pytest.approx(
        servo["quadlet"]["cycle_us"] / numbers["baseline"]["round_trip"]["p50_us"], abs=0.01
    )
    text = render(numbers)
    assert "interleaved with the block passes, p50 10.0 us" in text
    assert "block read, fit: r²" in text


def _with_regimes(raw_wakeups: int) -> BenchResult:
    run = synthetic_run()
    run.regimes = {
        "raw": Regime(1000, raw_wakeups, 0, 0),
        "floor": Regime(1000, 0, 0, 0),
        "quadlet": Regime(2000, 0, 0, 20),
        "block_raw": Regime(500, 0, 0, None),
        "block": Regime(800, 8, 400, None),
    }
    return run


def test_the_regime_of_each_half_and_a_warning_when_a_ratio_mixes_them() -> None:
    numbers = digest(_with_regimes(raw_wakeups=0))
    regime = numbers["regime"]
    assert regime["raw"]["calls"] == 1000 and regime["quadlet"]["peer_wakeups_per_call"] == 0.01
    assert regime["block"]["preemptions_per_call"] == 0.5
    assert regime["same_regime"] == {"quadlet": True, "frame_floor": True, "block": False}
    text = render(numbers)
    assert "block raw 0.00/?/0.00, blocks 0.01/?/0.50" in text
    assert "warning: the block figures divide halves that ran in different regimes" in text
    mixed = render(digest(_with_regimes(raw_wakeups=900)))
    assert "warning: the quadlet and frame floor and block figures" in mixed
    assert "regime:" not in render(digest(synthetic_run()))  # a run that counted nothing


def test_the_frame_floor_against_raw_and_under_the_read() -> None:
    run = synthetic_run()
    run.frame_floor = [24.0] * 99 + [500.0]  # a stall moves the mean, not the median
    numbers = digest(run)
    floor = numbers["frame_floor"]
    unit = numbers["baseline"]["round_trip"]["p50_us"]
    assert floor["frames"] == 3 and floor["p50_us"] == 24.0 and floor["count"] == 100
    assert floor["x_p50"] == pytest.approx(24.0 / unit, abs=0.01)
    read = numbers["quadlet"]["read"]["p50_us"]
    assert floor["read_above_p50_us"] == pytest.approx(read - 24.0, abs=0.01)
    text = render(numbers)
    assert f"floor): p50 24.0 us, x{24.0 / unit:.2f} raw; the read's p50 is" in text
    assert "frame_floor" not in digest(synthetic_run())  # a target of another transport
