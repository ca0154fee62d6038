"""The block line of ``fw1394 bench``: per-size medians, then Theil-Sen, against planted faults."""

from __future__ import annotations

import numpy as np
import pytest

from fw1394.experiments import thesis
from fw1394.experiments.fit import fit_line, fit_medians
from fw1394.experiments.run_settings import FULL, QUICK, Settings

BASE_US = thesis.BLOCK_READ_BASE_US
SLOPE = 32 / 4000  # about the virtual bus's read slope: 4 Gbit/s


def bench_like(
    sizes: tuple[int, ...], passes: int, *, cold_size: int, seed: int
) -> dict[int, list[float]]:
    """Times as the bench sees them: a known line, noise, stalls and cold first samples.

    Each pass starts with ``cold_size`` (as the old fixed shuffles put one size
    first after every raw round) and that first transaction pays a wake-up of
    80-150 us in four passes of five; one transaction in twelve, anywhere, is a
    scheduler stall of 0.2-5 ms.
    """
    rng = np.random.default_rng(seed)
    samples: dict[int, list[float]] = {size: [] for size in sizes}
    for number in range(passes):
        order = [cold_size, *rng.permutation([s for s in sizes if s != cold_size])]
        for position, size in enumerate(order):
            time = BASE_US + SLOPE * size + rng.gamma(4.0, 0.5)
            if position == 0 and number % 5:
                time += rng.uniform(80.0, 150.0)
            if rng.random() < 1 / 12:
                time += rng.uniform(200.0, 5000.0)
            samples[size].append(float(time))
    return samples


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
@pytest.mark.parametrize("plan", [QUICK, FULL], ids=["quick", "full"])
def test_the_line_is_recovered_through_stalls_and_cold_samples(plan: Settings, seed: int) -> None:
    samples = bench_like(plan.block_sizes, plan.block_passes, cold_size=64, seed=seed)
    fit = fit_medians(samples)
    noise_median = 4.0 * 0.5 - 0.33 * 0.5  # gamma(4, 0.5): median about 1.84 us
    assert fit.base_us == pytest.approx(BASE_US + noise_median, abs=1.0)
    assert fit.slope_us_per_quadlet == pytest.approx(SLOPE, rel=0.25)
    assert fit.points == len(plan.block_sizes)


def test_one_size_gone_wrong_does_not_move_the_line() -> None:
    # The cold size's median is a wake-up; least squares would lift the base by about 10 us.
    sizes = QUICK.block_sizes
    medians = [BASE_US + SLOPE * size + (110.0 if size == 64 else 0.0) for size in sizes]
    fit = fit_line(sizes, medians)
    assert fit.base_us == pytest.approx(BASE_US)
    assert fit.slope_us_per_quadlet == pytest.approx(SLOPE)


def test_a_robust_line_reports_how_badly_the_points_fit_it() -> None:
    # Nine points at 10 us and one at 100: the line is the flat nine, and the one it
    # misses leaves more squared error than the points' own spread, so r² is below 0.
    sizes = list(range(1, 11))
    fit = fit_line(sizes, [10.0] * 9 + [100.0])
    assert (fit.base_us, fit.slope_us_per_quadlet) == (10.0, 0.0)
    assert fit.r_squared == pytest.approx(1 - 90.0**2 / (9 * 9.0**2 + 81.0**2))
    assert fit.residual_iqr_us == 0.0
    scattered = fit_line(sizes, [10.0 + (2.0 if size % 2 else -2.0) for size in sizes])
    assert scattered.residual_iqr_us == pytest.approx(4.0)
    assert scattered.r_squared == pytest.approx(0.0)  # the line is the points' mean
