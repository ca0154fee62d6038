"""tshark's options where a user reaches for them: ``dissect -T fields -e -E``, ``-x``,
``-T json``/``ek``, ``-w`` with ``-Y``, checked against the real tshark on one trace."""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views.lua_dissector import generate
from fw1394.cli.main import main

TSHARK = shutil.which("tshark")
pytestmark = [
    pytest.mark.skipif(TSHARK is None, reason="tshark is not installed (apt-get install tshark)"),
    pytest.mark.tshark,
    pytest.mark.process,
]


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("options") / "bus.pcapng"
    scenario = Scenario(busy_every=13, lost_every=17, separate_acks=True)
    write_trace(str(path), simulate(300, scenario))
    return path


@pytest.fixture(scope="module")
def lua(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    path.write_text(generate())
    return path


def tshark(lua: Path, *arguments: str) -> str:
    command = [TSHARK or "tshark", "-2", "-X", f"lua_script:{lua}", *arguments]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return result.stdout


def dissect(capsys: pytest.CaptureFixture[str], *arguments: str) -> str:
    assert main(["dissect", *arguments]) == 0
    return capsys.readouterr().out


#: Offsets are left out: Wireshark 4.0's Lua prints the 48-bit field as 64 bits.
FIELDS = ["frame.number", "fw1394.tcode", "fw1394.dst_id", "fw1394.src_id", "fw1394.tlabel"]
FIELDS += ["fw1394.rcode", "fw1394.ack", "fw1394.response_time", "fw1394.request_in"]
FIELDS += ["fw1394.response_in", "fw1394.header_crc.status", "fw1394.kind"]


def test_fields_are_tsharks(lua: Path, trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    extract = [part for name in FIELDS for part in ("-e", name)]
    options = ["-T", "fields", *extract, "-E", "separator=,", "-E", "header=y"]
    theirs = tshark(lua, "-r", str(trace), *options)
    ours = dissect(capsys, str(trace), *options)
    assert ours.splitlines()[0] == ",".join(FIELDS)
    assert len(ours.splitlines()) > 300
    assert ours == theirs


def test_hex_dump_shows_the_frames_bytes(
    lua: Path, trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    def dumped(text: str) -> list[str]:
        return [
            " ".join(re.findall(r"\b[0-9a-f]{2}\b", line[6:54]))
            for line in text.splitlines()
            if re.match(r"[0-9a-f]{4}  ", line)
        ]

    theirs = dumped(tshark(lua, "-r", str(trace), "-x", "-c", "40"))
    ours = dumped(dissect(capsys, str(trace), "-x", "-c", "40"))
    assert len(ours) > 40 and ours == theirs


def test_json_array_and_ek_lines(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    lines = [json.loads(line) for line in dissect(capsys, str(trace), "--json").splitlines()]
    assert json.loads(dissect(capsys, str(trace), "-T", "json")) == lines
    ek = dissect(capsys, str(trace), "-T", "ek").splitlines()
    assert [json.loads(line) for line in ek] == lines


def test_saving_a_filtered_trace_keeps_each_packets_ack(
    lua: Path, trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    saved = tmp_path / "responses.pcapng"
    chosen = "fw1394.tcode == 6"
    assert main(["dissect", str(trace), "-Y", chosen, "-w", str(saved)]) == 0
    assert capsys.readouterr().out == ""
    # In the original, which frames are read responses and which acks follow them.
    rows = tshark(lua, "-r", str(trace), "-T", "fields", "-e", "fw1394.tcode", "-e", "fw1394.ack")
    kinds = [line.split("\t") for line in rows.splitlines()]
    expected = []
    for index, (tcode, _) in enumerate(kinds):
        if tcode == "6":
            expected.append(("6", ""))
            after = kinds[index + 1] if index + 1 < len(kinds) else None
            if after is not None and after[0] == "" and after[1]:
                expected.append(("", after[1]))
    saved_rows = tshark(
        lua, "-r", str(saved), "-T", "fields", "-e", "fw1394.tcode", "-e", "fw1394.ack"
    )
    assert [tuple(line.split("\t")) for line in saved_rows.splitlines()] == expected
    assert sum(1 for tcode, _ in expected if tcode == "") > 10  # acks came along


@pytest.mark.parametrize(
    ("arguments", "message"),
    [
        (["-e", "fw1394.tcode"], "add -T fields"),
        (["-T", "fields"], "needs at least one -e"),
        (["-T", "fields", "-e", "fw1394.bogus"], "unknown field"),
        (["-T", "fields", "-e", "frame.number", "-E", "colour=red"], "separator=C"),
        (["--stats", "-w", "x.pcapng"], "-w saves packets"),
    ],
)
def test_option_errors_are_one_line(
    trace: Path, arguments: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dissect", str(trace), *arguments]) == 2
    out, err = capsys.readouterr()
    assert out == "" and len(err.splitlines()) == 1 and message in err


def test_statistics_after_the_packets(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """-q -z: the packets of each node pair counted, the latency and the problems,
    against the same trace read packet by packet."""
    rows = dissect(capsys, str(trace), "--json").splitlines()
    packets = [json.loads(row) for row in rows]
    pairs: dict[str, int] = {}
    for packet in packets:
        if "source_id" in packet and "tcode" in packet:
            key = f"{packet['source_id']:04x} -> {packet['destination_id']:04x}"
            pairs[key] = pairs.get(key, 0) + 1
    text = dissect(capsys, str(trace), "-q", "-z", "conv", "-z", "latency", "-z", "expert")
    assert "read_quadlet_response" not in text  # -q: no packet rows
    counted = {}
    for line in text.splitlines():
        found = re.fullmatch(r"\s+(\S+ -> \S+)\s+(\d+)", line)
        if found:
            counted[found.group(1)] = found.group(2)
    assert {key: int(n) for key, n in counted.items()} == pairs
    assert "latency (all): n=" in text and "Expert information" in text
    stats = json.loads(dissect(capsys, str(trace), "--stats", "--json"))
    assert f"total                        {stats['errors']['total']}" in text
