"""Side effects seen where they happen: register strobes of packets that must be dropped.

The contract (thesis) drops a packet with a bad header CRC, for another node,
of an unsupported tcode or with a damaged length: it must not touch a register
either. The planted ``bad-crc-write`` defect performs a quadlet write whose
header CRC fails; the ``side-effect`` oracle must see the strobe in every
seeded campaign, on a served register bus and through the ``[effects]``
signals of a design with its own registers. Registers a design writes by
itself are declared in the map (``own``) so the model stays in step.
"""

from __future__ import annotations

import random
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import pytest

from fw1394.crc import header_crc
from fw1394.fuzz.campaign import run
from fw1394.fuzz.contract import CONTRACTS, silence_reason
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.offsets import offset_model
from fw1394.fuzz.rtl_target import RtlTarget
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.trial import wire_of
from fw1394.packets import QuadletWriteRequest
from fw1394.rtl.portmap import PortMapError, harness_verilog, load
from fw1394.rtl.simulation import missing_tools

HERE = Path(__file__).parent
Test = TypeVar("Test", bound=Callable[..., None])


def simulated(test: Test) -> Test:
    """Marks of a test that runs the simulator."""
    for mark in (
        pytest.mark.rtl,
        pytest.mark.iverilog,
        pytest.mark.process,
        pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
    ):
        test = mark(test)
    return test


def _quadlet_write(destination: int, offset: int, value: int, *, good_crc: bool) -> bytes:
    # IEEE 1394 quadlet write request (tcode 0), laid out from the standard:
    # destination, tlabel/rt/tcode/pri, source, offset, data, header CRC.
    head = (
        destination.to_bytes(2, "big")
        + bytes([1 << 2, 0x0 << 4])
        + (0xFFC1).to_bytes(2, "big")
        + offset.to_bytes(6, "big")
        + value.to_bytes(4, "big")
    )
    crc = header_crc(head)
    return head + (crc if good_crc else crc ^ 0x1).to_bytes(4, "big")


@simulated
@pytest.mark.parametrize("spec", ["thesis", "thesis-own"], ids=["served-bus", "effects-signals"])
@pytest.mark.parametrize("plant", [False, True], ids=["sound", "bad-crc-write"])
def test_a_dropped_write_that_strobes_is_seen(spec: str, plant: bool) -> None:
    defects = frozenset({"bad-crc-write"}) if plant else frozenset()
    target = RtlTarget(load(spec), node_id=0xFFC0, defects=defects)
    try:
        packets = [
            _quadlet_write(0xFFC0, 0x20, 0xCAFE0001, good_crc=False),
            _quadlet_write(0xFFC0, 0x21, 0xCAFE0002, good_crc=True),
            _quadlet_write(0xFFC7, 0x22, 0xCAFE0003, good_crc=True),  # another node
        ]
        target.exchange([wire_of(raw) for raw in packets], 0.0)
        bad, good, other = target.side_effects()
    finally:
        target.close()
    assert good == [("write", 0x21, 0xCAFE0002)]
    assert other == []
    assert bad == ([("write", 0x20, 0xCAFE0001)] if plant else [])


def test_every_seeded_campaign_sends_many_bad_crc_quadlet_writes() -> None:
    # What makes the finding certain in a 2000-case campaign: dozens of chances.
    model = offset_model("snake2010")
    for seed in range(10):
        generator = Generator(0xFFC0, model, random.Random(seed))
        chances = 0
        for _ in range(2000):
            wire = wire_of(generator.case()[0])
            if isinstance(wire.packet, QuadletWriteRequest):
                reason = silence_reason(wire.packet, wire.damaged, 0xFFC0, CONTRACTS["thesis"])
                chances += reason == "bad-header-crc"
        assert chances >= 20, seed


@simulated
@pytest.mark.parametrize("seed", [0, 3, 7])
def test_the_planted_bad_crc_write_is_found_by_the_side_effect_oracle(seed: int) -> None:
    # These seeds send their first bad-CRC quadlet write within 40 cases.
    report = run(
        Settings("rtl:thesis", defects=("bad-crc-write",), seed=seed, max_cases=40, shrink_budget=0)
    )
    keys = {(f.oracle, f.signature) for f in report.findings}
    assert ("side-effect", "bad-header-crc:write:write") in keys
    finding = next(f for f in report.findings if f.oracle == "side-effect")
    assert "<- 0x" in finding.observed


@simulated
def test_a_sound_campaign_has_no_side_effects() -> None:
    report = run(Settings("rtl:thesis-own", seed=5, max_cases=60, shrink_budget=0))
    assert report.findings == [] and report.checks["side-effect"] > 10


@simulated
def test_registers_the_design_writes_itself_keep_the_model_in_step(tmp_path: Path) -> None:
    # variant_self_write.v writes register 3 every 64 cycles. Declared (own = [3]):
    # no finding. Undeclared: the sweep sees the model out of step, and the
    # writes land while dropped packets are served.
    declared = run(Settings(f"rtl:{HERE / 'self_write.toml'}", max_cases=70, shrink_budget=0))
    assert declared.findings == []
    text = (HERE / "self_write.toml").read_text().replace("own = [3]\n", "")
    path = tmp_path / "undeclared.toml"
    path.write_text(text.replace('"variant_self_write.v"', f'"{HERE / "variant_self_write.v"}"'))
    undeclared = run(Settings(f"rtl:{path}", max_cases=70, shrink_budget=0))
    oracles = {f.oracle for f in undeclared.findings}
    assert {"reply", "side-effect"} <= oracles, [
        (f.oracle, f.signature) for f in undeclared.findings
    ]


# -- the map ---------------------------------------------------------------------------
def test_effects_signals_reach_the_harness() -> None:
    text = harness_verilog(load("thesis-own"))
    assert "wire fx_wr = (|dut.reg_wr) | (|dut.reg_blk_wr);" in text
    assert "wire [15:0] fx_addr = dut.reg_addr;" in text
    served = harness_verilog(load("thesis"))
    assert "wire fx_wr = reg_wr | reg_blk_wr;" in served


@pytest.mark.parametrize(
    ("extra", "message"),
    [
        ('[effects]\nrd = "regs.rd"\n', "needs wr"),
        ('[effects]\nwr = "regs..wr"\n', "must name a signal"),
        ('[effects]\nwr = "w"\nstrobe = "s"\n', "unknown key 'strobe'"),
        ("[registers]\nown = [-1]\n", "own must list register indices"),
    ],
)
def test_bad_effects_and_own_keys_are_refused(tmp_path: Path, extra: str, message: str) -> None:
    text = load("thesis-own").path.read_text().split("[effects]")[0]
    text = text.replace("@hdl/", str(load("thesis-own").sources[0].parent) + "/")
    path = tmp_path / "map.toml"
    path.write_text(text + extra)
    with pytest.raises(PortMapError, match=message):
        load(path)
