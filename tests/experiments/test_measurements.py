"""The block plan of ``fw1394 bench``: raw rounds and block passes, ABAB, on a fake clock."""

from __future__ import annotations

from types import SimpleNamespace

import pytest

from fw1394.experiments import regime as regime_module
from fw1394.experiments import timing
from fw1394.experiments.baseline import Baseline
from fw1394.experiments.measurements import measure_blocks_interleaved
from fw1394.experiments.regime import SETTLE_MIN_S, Regime
from fw1394.experiments.run_settings import FULL, QUICK, Settings
from fw1394.progress import Progress
from fw1394.transport.media.idle import ENVIRONMENT

COLD_US = 300.0
RAW_US = 15.0


class Peer:
    """A target on a fake clock: a transaction costs 40 us plus 0.01 us a quadlet, but
    the first one after a raw round costs ``COLD_US`` (the node slept through it)."""

    def __init__(self) -> None:
        self.now_ns = 0
        self.asleep = True
        self.calls: list[tuple[str, int]] = []

    def _transaction(self, kind: str, quadlets: int) -> None:
        cost = COLD_US if self.asleep else 40.0 + 0.01 * quadlets
        self.asleep = False
        self.now_ns += int(cost * 1000)
        self.calls.append((kind, quadlets))

    def read_quadlet(self) -> None:
        self._transaction("read", 1)

    def write_quadlet(self) -> None:
        self._transaction("write", 1)

    def read_block(self, quadlets: int) -> None:
        self._transaction("read", quadlets)

    def write_block(self, quadlets: int) -> None:
        self._transaction("write", quadlets)

    def peer_pids(self) -> list[int]:
        return []

    def describe(self) -> dict[str, object]:
        return {}


class RawRounds:
    """The echo's rounds: each one lets the peer fall asleep and is recorded."""

    def __init__(self, peer: Peer) -> None:
        self.peer = peer
        self.rounds: list[tuple[int, int, int]] = []  # (count, warmup, block calls before)

    def round(self, count: int, *, warmup: int = 0) -> Baseline:
        self.rounds.append((count, warmup, len(self.peer.calls)))
        self.peer.asleep = True
        return Baseline([RAW_US] * count, [RAW_US + 1] * max(count // 4, 10), 0)


@pytest.fixture
def peer(monkeypatch: pytest.MonkeyPatch) -> Peer:
    peer = Peer()
    monkeypatch.setattr(timing, "time", SimpleNamespace(perf_counter_ns=lambda: peer.now_ns))
    return peer


def test_every_pass_follows_a_raw_round_and_no_sample_is_a_wake_up(peer: Peer) -> None:
    raw = RawRounds(peer)
    sizes = (1, 8, 64, 512)
    blocks, floor = measure_blocks_interleaved(
        peer, raw, sizes, 6, raw_count=50, warmup=30, progress=Progress(enabled=False)
    )
    assert blocks.sizes == list(sizes) and blocks.passes == 6
    for samples in (blocks.read, blocks.write):
        assert sorted(samples) == list(sizes)
        assert all(len(samples[size]) == 6 for size in sizes)
        # Only the warm-up after each raw round pays the wake-up; every sample is warm.
        assert max(max(times) for times in samples.values()) < 50
        assert samples[512] == [pytest.approx(40 + 5.12, abs=0.01)] * 6
    # Raw and block rounds alternate, one raw round before each pass, each round warmed up.
    per_pass = [calls for _, _, calls in raw.rounds]
    assert len(raw.rounds) == 6 and per_pass == sorted(set(per_pass))
    assert all(warmup >= 1 and count == 50 for count, warmup, _ in raw.rounds)
    transactions = 2 * len(sizes)
    ends = [*per_pass[1:], len(peer.calls)]
    warmups = [end - start - transactions for start, end in zip(per_pass, ends, strict=True)]
    assert warmups == [2 * 30] + [2 * timing.SWITCH_WARMUP] * 5
    # The block figures' unit is these rounds' raw round trips alone.
    assert len(floor.small) == 6 * 50 and floor.unit_us == RAW_US


def test_every_round_starts_settled_and_each_half_is_counted(
    peer: Peer, monkeypatch: pytest.MonkeyPatch
) -> None:
    raw = RawRounds(peer)
    settled: list[tuple[float, int, int]] = []  # (seconds, raw rounds so far, block calls so far)

    def sleep(seconds: float) -> None:
        settled.append((seconds, len(raw.rounds), len(peer.calls)))

    monkeypatch.setattr(regime_module, "_sleep", sleep)
    monkeypatch.setenv(ENVIRONMENT, "adaptive")
    sizes = (1, 8, 64, 512)
    regimes = (Regime(), Regime())
    measure_blocks_interleaved(
        peer, raw, sizes, 6, raw_count=50, warmup=30, progress=Progress(enabled=False),
        regimes=regimes,
    )  # fmt: skip
    assert [seconds for seconds, _, _ in settled] == [SETTLE_MIN_S] * 12
    starts = [calls for _, _, calls in raw.rounds]
    for number in range(6):
        # Before the raw round: the previous pass is over, the raw round not begun.
        assert settled[2 * number][1:] == (number, starts[number])
        # Before the pass: its raw round is over, none of its block calls made.
        assert settled[2 * number + 1][1:] == (number + 1, starts[number])
    raw_regime, block_regime = regimes
    # Each raw round: 50 small and 12 block-sized round trips after 10 warm-ups.
    assert raw_regime.calls == 6 * (50 + 12 + timing.SWITCH_WARMUP)
    assert block_regime.calls == len(peer.calls)
    assert block_regime.peer_wakeups == 0  # a target without processes has no peers to count


@pytest.mark.parametrize("plan", [QUICK, FULL], ids=["quick", "full"])
def test_each_size_is_sampled_often_enough_for_a_median(plan: Settings) -> None:
    # A size's median holds while fewer than half its samples stall; with one sample a
    # pass it is the pass count that gives each size its samples.
    assert plan.block_passes >= 10
    assert len(plan.block_sizes) >= 10 and plan.block_sizes[0] == 1
    assert plan.block_sizes[-1] == 512
