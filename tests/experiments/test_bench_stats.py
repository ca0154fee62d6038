"""The statistics of ``fw1394 bench``: bands, the linear fit, the servo budget, summaries."""

from __future__ import annotations

import numpy as np
import pytest

from fw1394.experiments import servo, thesis
from fw1394.experiments.bands import find_bands
from fw1394.experiments.fit import LineFit, fit_line, fit_medians
from fw1394.experiments.summary import summarize
from fw1394.experiments.timing import MeasurementError, TargetError, time_calls


def mixture(
    centers: tuple[float, ...],
    shares: tuple[float, ...],
    spread: float,
    count: int = 9000,
    outliers: float = 0.01,
    seed: int = 1,
) -> np.ndarray:
    """Bands of normal noise around ``centers``, plus scheduler-stall outliers of 0.1-2 ms."""
    rng = np.random.default_rng(seed)
    which = rng.choice(len(centers), size=count, p=shares)
    samples = np.asarray(centers)[which] + rng.normal(0.0, spread, count)
    stalls = int(count * outliers)
    samples[:stalls] = rng.uniform(100.0, 2000.0, stalls)
    return samples


def centres(samples: np.ndarray | list[float]) -> list[float]:
    return [band.center_us for band in find_bands(list(samples))]


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_the_thesis_read_bands_are_found(seed: int) -> None:
    samples = mixture(thesis.QUADLET_READ_BANDS_US, (0.7, 0.2, 0.1), 1.0, seed=seed)
    bands = find_bands(list(samples))
    assert centres(samples) == pytest.approx(thesis.QUADLET_READ_BANDS_US, abs=0.5)
    # The outliers go to the slowest band, so its share is a little above 10 %.
    assert [band.share for band in bands] == pytest.approx([0.7, 0.2, 0.11], abs=0.025)
    assert sum(band.count for band in bands) == len(samples)
    assert bands[0].high_us == bands[1].low_us  # split at the valley, nothing lost


def test_the_thesis_write_bands_are_found() -> None:
    samples = mixture(thesis.QUADLET_WRITE_BANDS_US, (0.8, 0.2), 1.0)
    assert centres(samples) == pytest.approx(thesis.QUADLET_WRITE_BANDS_US, abs=0.5)


def test_bands_of_a_microsecond_clock_are_found() -> None:
    # Times read off a 1 us clock: histogram bins narrower than the clock would comb.
    samples = np.round(mixture(thesis.QUADLET_READ_BANDS_US, (0.7, 0.2, 0.1), 1.0))
    assert centres(samples) == pytest.approx(thesis.QUADLET_READ_BANDS_US, abs=0.5)


def test_a_few_hundred_samples_are_enough() -> None:
    samples = mixture(thesis.QUADLET_READ_BANDS_US, (0.7, 0.2, 0.1), 1.0, count=500, seed=4)
    assert centres(samples) == pytest.approx(thesis.QUADLET_READ_BANDS_US, abs=1.0)


def test_bands_closer_than_their_noise_are_one() -> None:
    # 7 us apart with 2 us of noise each: the histogram does not dip to half between them.
    samples = mixture((42.0, 49.0), (0.67, 0.33), 2.0)
    assert len(find_bands(list(samples))) == 1


def test_one_skewed_hump_is_one_band() -> None:
    rng = np.random.default_rng(5)
    assert len(find_bands(list(rng.lognormal(np.log(100), 0.2, 9000)))) == 1
    assert len(find_bands(list(rng.gamma(3.0, 10.0, 9000) + 60))) == 1


def test_a_sparse_tail_is_not_a_band() -> None:
    rng = np.random.default_rng(6)
    hump = rng.gamma(3.0, 10.0, 8500) + 60
    tail = rng.uniform(150.0, 1000.0, 500)  # 5.6 % of the samples, but spread thin
    assert len(find_bands([*hump, *tail])) == 1


def test_a_small_bump_is_dropped() -> None:
    samples = mixture((30.0, 60.0), (0.99, 0.01), 1.0, outliers=0.0)
    assert centres(samples) == pytest.approx([30.0], abs=0.5)


def test_degenerate_samples() -> None:
    assert find_bands([]) == []
    (band,) = find_bands([5.0] * 10)
    assert (band.center_us, band.count, band.share) == (5.0, 10, 1.0)


def test_a_line_is_recovered_with_its_throughput() -> None:
    slope = 32 / thesis.BLOCK_READ_MBIT_S
    sizes = list(range(1, 513))
    fit = fit_line(sizes, [thesis.BLOCK_READ_BASE_US + slope * s for s in sizes])
    assert fit.base_us == pytest.approx(thesis.BLOCK_READ_BASE_US)
    assert fit.mbit_s == pytest.approx(thesis.BLOCK_READ_MBIT_S)
    assert fit.r_squared == pytest.approx(1.0)
    assert fit.at(512) == pytest.approx(33.2 + 512 * slope)


def test_medians_keep_outliers_from_tilting_the_line() -> None:
    rng = np.random.default_rng(7)
    slope = 32 / thesis.BLOCK_WRITE_MBIT_S
    samples = {
        size: list(thesis.BLOCK_WRITE_BASE_US + slope * size + rng.normal(0, 2.0, 9))
        for size in range(1, 513)
    }
    for size in range(400, 513, 3):  # stalls that hit the large sizes
        samples[size][0] = 5000.0
    fit = fit_medians(samples)
    assert fit.base_us == pytest.approx(thesis.BLOCK_WRITE_BASE_US, abs=0.5)
    assert fit.mbit_s == pytest.approx(thesis.BLOCK_WRITE_MBIT_S, rel=0.05)


def test_a_flat_or_falling_line_has_no_throughput() -> None:
    assert fit_line([1, 2, 3], [10.0, 10.0, 10.0]).mbit_s is None
    assert fit_line([1, 2, 3], [12.0, 11.0, 10.0]).mbit_s is None
    with pytest.raises(ValueError, match="two distinct"):
        fit_line([4, 4], [1.0, 2.0])


def test_the_thesis_servo_arithmetic() -> None:
    quadlet = servo.quadlet_loop_us(thesis.QUADLET_READ_MEAN_US, thesis.QUADLET_WRITE_MEAN_US)
    assert quadlet == pytest.approx(452.9)  # "about 453 us"
    budget = servo.budget("quadlet", quadlet)
    assert round(budget.left_us[1000]) == thesis.QUADLET_LEFT_US[1000]
    assert budget.left_us[8000] < 0 and budget.left_us[10000] < 0  # "not even feasible"
    stated = servo.budget("block", thesis.BLOCK_LOOP_US)
    assert stated.left_us == pytest.approx(thesis.BLOCK_LEFT_US)
    assert stated.as_dict()["feasible"] == {"1000": True, "8000": True, "10000": True}


def test_the_block_cycle_uses_the_real_time_block_sizes() -> None:
    read = LineFit(thesis.BLOCK_READ_BASE_US, 32 / thesis.BLOCK_READ_MBIT_S, 1.0, 0.0, 512)
    write = LineFit(thesis.BLOCK_WRITE_BASE_US, 32 / thesis.BLOCK_WRITE_MBIT_S, 1.0, 0.0, 512)
    # 32-quadlet read + 7-quadlet write on the thesis's own lines: its "about 65 us".
    cycle = servo.block_loop_us(read, write)
    assert cycle == pytest.approx(33.2 + 32 * 32 / 360 + 30.7 + 7 * 32 / 290)
    assert 63.9 < cycle < 68


def test_summary_percentiles_and_ratios() -> None:
    summary = summarize([float(v) for v in range(1, 101)])
    assert (summary.count, summary.mean_us, summary.min_us, summary.max_us) == (100, 50.5, 1, 100)
    assert summary.p50_us == pytest.approx(50.5)
    assert summary.p90_us == pytest.approx(90.1)
    assert summary.p99_us == pytest.approx(99.01)
    row = summary.as_dict(unit_us=10.0)
    assert row["x_mean"] == 5.05 and row["x_p99"] == 9.9
    with pytest.raises(ValueError):
        summarize([])


def test_failed_calls_are_repeated_then_the_target_is_given_up() -> None:
    calls = iter(range(10_000))

    def flaky() -> None:
        if next(calls) % 10 == 3:
            raise TargetError("lost")

    samples, failures = time_calls(flaky, 100, warmup=5)
    # 105 successful calls need 117 attempts: every tenth one (3, 13, ..., 113) fails.
    assert len(samples) == 100 and failures == 12
    assert all(sample >= 0 for sample in samples)

    def dead() -> None:
        raise TargetError("gone")

    with pytest.raises(MeasurementError, match="stopped answering"):
        time_calls(dead, 10)
