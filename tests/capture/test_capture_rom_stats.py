"""Configuration ROM decoding with CRC-16 checks, and bounded-memory statistics."""

from __future__ import annotations

import numpy as np

from fw1394.capture.analysis import rom_decode as rom
from fw1394.capture.analysis.csr import csr_name
from fw1394.capture.analysis.stats import LatencyHistograms, Sample

ROM = rom.build_rom(0x0010DC, 0x1F0, 0x0010DC0001234567, "Linux Firewire", "Juju")


def quadlets(values: list[int]) -> dict[int, int]:
    return {0x400 + 4 * index: value for index, value in enumerate(values)}


def test_rom_decodes_with_good_crcs() -> None:
    report = rom.decode_rom(quadlets(ROM))
    assert report.bus_info_crc_ok and report.bus_info["bus_name"] == rom.BUS_NAME_1394
    assert report.eui64 == 0x0010DC0001234567
    assert [b.kind for b in report.blocks] == ["root_directory", "leaf", "leaf", "unit_directory"]
    assert all(block.crc_ok for block in report.blocks)
    assert [b.text for b in report.blocks if b.text] == ["Linux Firewire", "Juju"]
    keys = [entry["key"] for entry in report.blocks[0].entries]
    assert keys == ["Vendor", "Descriptor", "Model", "Descriptor", "Node_Capabilities", "Unit"]
    assert not report.missing


def test_rom_crc_errors_and_missing_quadlets_are_reported() -> None:
    damaged = list(ROM)
    damaged[7] ^= 0x100  # inside the root directory
    report = rom.decode_rom(quadlets(damaged))
    assert report.blocks[0].crc_ok is False
    partial = quadlets(ROM)
    del partial[0x404 + 4 * 10]
    report = rom.decode_rom(partial)
    assert report.missing and any(block.crc_ok is None for block in report.blocks)
    assert "not read" in rom.report_lines(report)[-1]


def test_rom_decoder_survives_garbage() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        values = rng.integers(0, 2**32, 64, dtype=np.uint64).tolist()
        report = rom.decode_rom(quadlets([int(v) for v in values]))
        assert len(report.blocks) <= 64
        rom.report_lines(report)


def test_csr_names() -> None:
    assert csr_name(0xFFFFF0000400) == "config ROM+0x0"
    assert csr_name(0xFFFFF000021C) == "BUS_MANAGER_ID"
    assert csr_name(0xFFFFF0000B00) == "FCP_COMMAND+0x0"
    assert csr_name(0x1000) is None


def test_percentiles_within_one_bin_of_the_exact_value() -> None:
    rng = np.random.default_rng(11)
    latency = rng.lognormal(10, 0.8, 200_000).astype(np.int64) + 1
    histograms = LatencyHistograms(2)
    for part in np.array_split(latency, 7):
        histograms.add(np.zeros(len(part), np.int64), part)
    summary = histograms.summary(0)
    assert summary["count"] == len(latency) and summary["max_ns"] == latency.max()
    for q in (50, 90, 99):
        exact = np.percentile(latency, q)
        assert abs(summary[f"p{q}_ns"] - exact) / exact < 0.012
    assert histograms.summary(1)["count"] == 0


def test_sample_stays_bounded_and_uniform() -> None:
    sample = Sample(capacity=1000)
    for start in range(0, 100_000, 9_000):
        values = np.arange(start, min(start + 9_000, 100_000), dtype=np.int64)
        sample.add(values, values, values)
    assert len(sample.latency) == 1000 and sample.seen == 100_000
    assert 35_000 < sample.latency.mean() < 65_000
