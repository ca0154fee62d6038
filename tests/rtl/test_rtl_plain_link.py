"""A second link design, written from the PHY-link facts (``plain_link.v``), end to end.

It waits for the PHY's second Grant before its read response, as the data
sheets require. The truth for the PHY model's side is the waveform: cycle by
cycle, the pins must show Grant, the ack, Hold, one more Idle, the release,
the packet separation, a second Grant, and only then the response. The
design's answers must match fw1394's engine with the thesis policy byte for
byte, and the design must work behind ``bus up --board rtl:`` (read, write,
capture) and ``fuzz run rtl:``.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from bus_support import bus_name, wait_until_gone

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.record import RecordType
from fw1394.cli.main import main
from fw1394.engine import THESIS_FPGA, Responder
from fw1394.fuzz.reference import board
from fw1394.fuzz.rtl_target import RtlTarget
from fw1394.fuzz.trial import wire_of
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
)
from fw1394.packets.asynchronous import decode_async, encode_async
from fw1394.rtl.portmap import load
from fw1394.rtl.simulation import Simulation, missing_tools

HERE = Path(__file__).parent
MAP = HERE / "plain_link.toml"
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
HOST = 0xFFC0
FAST_ARGS = ("--heartbeat", "0.1", "--lease", "2.0")


def _vcd_cycles(path: Path, names: tuple[str, ...]) -> list[dict[str, int]]:
    """Values of harness signals ``names`` just before each rising edge of sclk: what
    both sides put on the pins in that cycle (a VCD reader written here from the
    format: ``$var`` lines, then ``#time`` and value changes)."""
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
    values = dict.fromkeys(names, 0)
    changes: dict[str, int] = {}
    cycles = []
    tokens = iter(body.split())
    for token in tokens:
        if token.startswith("#"):
            if changes.get("sclk") == 1 and values["sclk"] == 0:
                cycles.append(dict(values))
            values.update(changes)
            changes = {}
            continue
        if token[0] in "bB":
            code, value = next(tokens), token[1:]
        elif token[0] in "01xzXZ":
            code, value = token[1:], token[0]
        else:
            continue
        if code in codes:
            changes[codes[code]] = int("".join(c if c in "01" else "0" for c in value), 2)
    return cycles


def test_the_read_response_waits_for_the_second_grant(tmp_path: Path) -> None:
    waves = tmp_path / "read.vcd"
    target = RtlTarget(load(MAP), node_id=HOST, waves=waves)
    raw = encode_async(QuadletReadRequest(destination_id=HOST, tlabel=1, source_id=0xFFC1))
    [reply] = target.exchange([wire_of(raw)], 0.0)
    violations = target.interface_violations()
    target.close()
    assert reply.ack == AckCode.ack_pending and reply.concatenated and violations == []
    samples = _vcd_cycles(waves, ("sclk", "phy", "mon"))
    # phy: bit 10 the PHY drives, bits 9-8 its CTL (CTL0 high); mon: bit 10 the
    # link drives, bits 9-8 its CTL, 7-0 its D (the canonical wrapper signals).
    cycles = [
        ("P" + "ISRG"[s["phy"] >> 8 & 3] if s["phy"] >> 10 & 1 else "-")
        + ("L" + "IHTX"[s["mon"] >> 8 & 3] if s["mon"] >> 10 & 1 else "-")
        for s in samples
    ]
    trace = " ".join(cycles)
    # The read's last bytes, then: the PHY's Grant and Idle, a cycle in which
    # neither side drives, the link's ack (one Transmit cycle at S400), Hold (a
    # concatenation request), one more Idle, the release and the turnaround.
    ack_at = cycles.index("-LT")
    assert cycles[ack_at - 3 : ack_at] == ["PG-", "PI-", "--"], trace
    assert cycles[ack_at + 1 : ack_at + 4] == ["-LH", "-LI", "--"], trace
    # The PHY owns the interface for the packet separation, then grants again;
    # nothing is transmitted before that second Grant.
    second = cycles.index("PG-", ack_at)
    assert set(cycles[ack_at + 4 : second]) == {"PI-"} and second - ack_at - 4 >= 4, trace
    # The 20-byte response, its closing Idle pair, the release.
    assert cycles[second + 1 : second + 3] == ["PI-", "--"], trace
    assert cycles[second + 3 : second + 23] == ["-LT"] * 20, trace
    assert cycles[second + 23 : second + 26] == ["-LI", "-LI", "--"], trace


def test_answers_like_the_engine_byte_for_byte() -> None:
    responder = Responder(0xFFC2, board("snake2010", 0), THESIS_FPGA)
    me = 0xFFC2
    packets = [
        QuadletReadRequest(destination_id=me, tlabel=1, source_id=HOST, offset=4),
        QuadletWriteRequest(destination_id=me, tlabel=2, source_id=HOST, offset=3, quadlet_data=7),
        QuadletReadRequest(destination_id=me, tlabel=3, source_id=HOST, offset=3),
        BlockWriteRequest(destination_id=me, tlabel=4, source_id=HOST, offset=0x11, data=b"\x80\0"),
        BlockReadRequest(destination_id=me, tlabel=5, source_id=HOST, offset=0x10, data_length=7),
        BlockReadRequest(destination_id=me, tlabel=6, source_id=HOST, offset=0, data_length=4096),
        BlockWriteRequest(destination_id=me, tlabel=7, source_id=HOST, offset=3, data=bytes(3000)),
        BlockReadRequest(destination_id=me, tlabel=8, source_id=HOST, offset=0, data_length=0),
        QuadletWriteRequest(
            destination_id=0xFFFF, tlabel=9, source_id=HOST, offset=3, quadlet_data=9
        ),
        QuadletReadRequest(destination_id=0xFFC5, tlabel=10, source_id=HOST, offset=0),
    ]
    raws = [encode_async(p) for p in packets]
    raws.append(raws[0][:-1] + bytes([raws[0][-1] ^ 1]))  # bad header CRC
    raws.append(raws[0] + b"\0\0\0\0")  # damaged length
    sim = Simulation(load(MAP), physical_id=2)
    try:
        answer = sim.exchange(raws, 0.002)
    finally:
        sim.close()
    assert answer["violations"] == []
    for raw, got in zip(raws, answer["replies"], strict=True):
        reply = responder.receive(raw, 0.002)
        response = None if reply.response is None else encode_async(reply.response).hex()
        assert got == [reply.ack, response, reply.concatenated], raw.hex()


def test_read_write_and_capture_on_the_virtual_bus(capsys: pytest.CaptureFixture[str]) -> None:
    name = bus_name("plain")
    try:
        up = ["bus", "up", "--name", name, "--nodes", "1", "--board", f"rtl:{MAP}"]
        assert main([*up, *FAST_ARGS, "--timeout", "60"]) == 0
        capsys.readouterr()
        assert main(["write", "--name", name, "0", "0x3", "0xbeef", "--timeout", "2"]) == 0
        with BusTap(name, ack_wait=0.5) as tap:
            assert main(["read", "--name", name, "0", "0x3", "--json", "--timeout", "2"]) == 0
            records = []
            while (record := tap.receive(0.5)) is not None:
                records.append(record)
        assert json.loads(capsys.readouterr().out.splitlines()[-1])["data"] == "0000beef"
        request, response = [r for r in records if r.record_type is RecordType.async_packet][-2:]
        assert request.ack == AckCode.ack_pending
        answer = decode_async(response.data)
        assert isinstance(answer, QuadletReadResponse) and answer.quadlet_data == 0xBEEF
        assert answer.problems == ()
    finally:
        assert main(["bus", "down", "--name", name]) == 0
    assert wait_until_gone(name) == []


def test_fuzzed_clean_with_every_oracle(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    findings = tmp_path / "findings"
    run = ["fuzz", "run", f"rtl:{MAP}", "--max-cases", "150", "--seed", "4"]
    assert main([*run, "--findings", str(findings), "--json", "--no-progress"]) == 0
    report = json.loads(capsys.readouterr().out)
    assert report["findings"] == [] and report["cases"] == 150
    for oracle in ("silence", "reply", "liveness", "state", "interface"):
        assert report["coverage"]["oracles"][oracle]["checks"] > 0, oracle
