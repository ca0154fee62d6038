"""Simulated time, not wall time; speeds and clock frequency of an RTL campaign.

Every wait of the PHY model is counted in SCLK cycles (the port map's [phy]
limits), and the parent waits for the simulator as long as it lives, so a
loaded machine cannot change a verdict: the same campaign beside a CPU hog
finds exactly what it finds alone. Packets go at S100, S200 or S400 (two,
four or eight bits per cycle on D, phy-link.md), read from the waveform.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.cli.main import main
from fw1394.engine import THESIS_FPGA, Responder
from fw1394.fuzz.campaign import run
from fw1394.fuzz.reference import board
from fw1394.fuzz.rtl_target import RtlTarget
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.trial import wire_of
from fw1394.packets import BlockReadRequest, QuadletReadRequest
from fw1394.packets.asynchronous import encode_async
from fw1394.rtl.portmap import load
from fw1394.rtl.simulation import Simulation, missing_tools

HERE = Path(__file__).parent
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
HOST = 0xFFC1


Verdicts = tuple[list[tuple[str, str, int]], int, dict[str, int], dict[str, int]]


def _verdicts(settings: Settings) -> Verdicts:
    report = run(settings)
    findings = sorted((f.oracle, f.signature, f.case) for f in report.findings)
    return (findings, report.cases, dict(report.checks), dict(report.violations))


def test_verdicts_do_not_change_when_the_machine_is_loaded() -> None:
    settings = Settings(
        "rtl:thesis",
        defects=("no-second-grant", "bad-crc-write"),
        seed=3,
        max_cases=40,
        shrink_budget=0,
        speed="mixed",
    )
    alone = _verdicts(settings)
    hog = [sys.executable, "-c", "while True: pass"]
    hogs = [subprocess.Popen(hog) for _ in range(3)]
    try:
        loaded = _verdicts(settings)
    finally:
        for process in hogs:
            process.kill()
            process.wait()
    assert loaded == alone
    assert {oracle for oracle, _, _ in alone[0]} >= {"interface", "side-effect"}


def test_limits_are_counted_in_clock_cycles(tmp_path: Path) -> None:
    # A 2 KiB block read keeps the interface about 2,100 cycles: beyond an
    # own_cycles of 1,000, within the default.
    text = (
        load("thesis").path.read_text().replace("ack_gap = 32", "ack_gap = 32\nown_cycles = 1000")
    )
    text = text.replace("@hdl/", str(load("thesis").sources[0].parent) + "/")
    path = tmp_path / "short.toml"
    path.write_text(text)
    read = BlockReadRequest(destination_id=0xFFC0, tlabel=1, source_id=HOST, data_length=2048)
    for spec, first in ((path, ["ownership"]), (load("thesis").path, [])):
        target = RtlTarget(load(spec), node_id=0xFFC0)
        try:
            target.exchange([wire_of(encode_async(read))], 0.0)
            # (the PHY takes the interface back: the link, still sending, contends)
            assert [v.split(":")[0] for v in target.interface_violations()][:1] == first
        finally:
            target.close()


@pytest.mark.parametrize(("speed", "bits"), [(0, 2), (1, 4), (2, 8)], ids=["S100", "S200", "S400"])
def test_each_speed_carries_its_bits_per_cycle(tmp_path: Path, speed: int, bits: int) -> None:
    waves = tmp_path / "speed.vcd"
    sim = Simulation(load("thesis"), physical_id=0, waves=waves, sclk_mhz=24.576)
    raw = encode_async(
        QuadletReadRequest(destination_id=0xFFC0, tlabel=2, source_id=HOST, offset=4)
    )
    try:
        answer = sim.exchange([raw], 0.001, speeds=[speed])
    finally:
        sim.close()
    responder = Responder(0xFFC0, board("snake2010", 0), THESIS_FPGA)
    reply = responder.receive(raw, 0.001)
    assert reply.response is not None
    assert answer["replies"] == [[reply.ack, encode_async(reply.response).hex(), True]]
    assert answer["violations"] == []
    # From the waveform: the cycles in which the link transmits the ack and the
    # 20-byte response, and the D lines outside the speed's stay low.
    runs = _transmit_runs(waves)
    assert [len(run) for run in runs[-2:]] == [8 // bits, 20 * 8 // bits]
    assert all(d & ((1 << (8 - bits)) - 1) == 0 for run in runs[-2:] for d in run)
    # The clock ran at the frequency asked for: a period of 1e6 / 24.576 ps.
    assert _period_ps(waves) in (40_690, 40_692)


def _signal_changes(path: Path, names: tuple[str, ...]) -> list[tuple[int, str, int]]:
    codes: dict[str, str] = {}
    scope: list[str] = []
    head, _, body = path.read_text().partition("$enddefinitions")
    for line in head.splitlines():
        words = line.split()
        if words[:1] == ["$scope"]:
            scope.append(words[2])
        elif words[:1] == ["$upscope"]:
            scope.pop()
        elif words[:1] == ["$var"] and scope == ["fw1394_harness"] and words[4] in names:
            codes[words[3]] = words[4]
    changes = []
    now = 0
    tokens = iter(body.split())
    for token in tokens:
        if token.startswith("#"):
            now = int(token[1:])
            continue
        if token[0] in "bB":
            code, value = next(tokens), token[1:]
        elif token[0] in "01xzXZ":
            code, value = token[1:], token[0]
        else:
            continue
        if code in codes:
            changes.append(
                (now, codes[code], int("".join(c if c in "01" else "0" for c in value), 2))
            )
    return changes


def _transmit_runs(path: Path) -> list[list[int]]:
    """D of the cycles the link transmits, in runs of consecutive cycles."""
    # mon: bit 10 the link drives, bits 9-8 its CTL (10: Transmit), 7-0 its D (D0 high).
    values = {"sclk": 0, "mon": 0}
    runs: list[list[int]] = []
    last = False
    for _, name, value in _signal_changes(path, ("sclk", "mon")):
        if name == "sclk" and value == 1 and values["sclk"] == 0:
            mon = values["mon"]
            sending = bool(mon >> 10 & 1 and mon >> 8 & 3 == 0b10)
            if sending and not last:
                runs.append([])
            if sending:
                runs[-1].append(mon & 0xFF)
            last = sending
        values[name] = value
    return runs


def _period_ps(path: Path) -> int:
    timescale = path.read_text().split("$timescale")[1].split("$end")[0].split()
    unit = {"1ps": 1, "1ns": 1000, "1fs": 0.001}["".join(timescale)]
    rises = [t for t, name, value in _signal_changes(path, ("sclk",)) if value == 1]
    return round((rises[-1] - rises[-2]) * unit)


def test_speed_and_clock_are_for_rtl_targets(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fuzz", "run", "inproc:memory", "--speed", "S100", "--max-cases", "1"]) == 2
    assert "for rtl: targets" in capsys.readouterr().err
    with pytest.raises(SystemExit) as exit_status:
        main(["fuzz", "run", "rtl:thesis", "--speed", "S800", "--max-cases", "1"])
    assert exit_status.value.code == 2
    assert "invalid choice: 'S800'" in capsys.readouterr().err
