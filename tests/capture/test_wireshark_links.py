"""Transaction links, CRC verdicts, node columns and offsets of the Wireshark dissector.

The generated Lua runs in the real tshark; every answer is checked against
fw1394's own dissection of the same trace (the transaction view's pairs and
latencies, the packet view's CRC checks).
"""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from bus_support import bus_name, wait_until_gone

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views.lua_dissector import generate
from fw1394.cli.main import main
from fw1394.host.bus_port import BusPort
from fw1394.packets import (
    AckCode,
    BlockReadResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    WriteResponse,
    encode,
)
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

TSHARK = shutil.which("tshark")
pytestmark = [
    pytest.mark.skipif(
        TSHARK is None, reason="tshark is not installed (Debian: apt-get install -y tshark)"
    ),
    pytest.mark.tshark,
    pytest.mark.process,
]
#: Wireshark's PI_ERROR (epan/proto.h), as -T fields prints an expert severity.
ERROR_SEVERITY = 0x00800000
LINK_FIELDS = ["fw1394.response_in", "fw1394.request_in", "fw1394.response_time"]
LINK_FIELDS += ["fw1394.attempts", "_ws.expert.message"]


@pytest.fixture(scope="module")
def lua(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    path.write_text(generate())
    return path


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Busy acks and retries, lost packets (answers without requests), corrupted data."""
    path = tmp_path_factory.mktemp("trace") / "bus.pcapng"
    scenario = Scenario(busy_every=13, lost_every=17, corrupt_every=19, separate_acks=True)
    write_trace(str(path), simulate(1500, scenario))
    return path


def tshark(lua: Path, trace: Path, *arguments: str) -> str:
    command = [TSHARK or "tshark", "-X", f"lua_script:{lua}", "-r", str(trace), *arguments]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "Lua Error" not in result.stdout + result.stderr
    return result.stdout


def tshark_fields(lua: Path, trace: Path, *fields: str) -> dict[int, dict[str, str]]:
    """Frame number -> {field: text} for the fields present, after two passes."""
    arguments = ["-2", "-T", "fields", "-e", "frame.number"]
    for field in fields:
        arguments += ["-e", field]
    frames = {}
    for line in tshark(lua, trace, *arguments).splitlines():
        number, *values = line.split("\t")
        frames[int(number)] = {f: v for f, v in zip(fields, values, strict=True) if v}
    return frames


def fw1394_json(capsys: pytest.CaptureFixture[str], *arguments: str) -> list[dict[str, object]]:
    assert main(["dissect", *arguments, "--json"]) == 0
    return [json.loads(line) for line in capsys.readouterr().out.splitlines()]


def with_message(frames: dict[int, dict[str, str]], text: str) -> set[int]:
    return {n for n, f in frames.items() if text in f.get("_ws.expert.message", "")}


def test_links_agree_with_the_transaction_view(
    lua: Path, trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    transactions = fw1394_json(capsys, str(trace), "--transactions")
    frames = tshark_fields(lua, trace, *LINK_FIELDS)
    answered = [t for t in transactions if "latency_ns" in t]
    assert len(answered) > 200 and any(t["attempts"] != 1 for t in answered)
    for t in answered:
        request, response = frames[int(str(t["frame"]))], frames[int(str(t["response_frame"]))]
        assert int(response["fw1394.request_in"]) == t["frame"], t
        assert round(float(response["fw1394.response_time"]) * 1e9) == t["latency_ns"], t
        assert int(response["fw1394.attempts"]) == t["attempts"], t
        assert int(request["fw1394.response_in"]) == t["response_frame"], t
    linked = {n for n, f in frames.items() if "fw1394.request_in" in f}
    assert linked == {t["response_frame"] for t in answered}
    unsolicited = {t["response_frame"] for t in transactions if t["kind"] == "unsolicited"}
    assert unsolicited and with_message(frames, "Response without a request") == unsolicited
    unanswered = {t["frame"] for t in transactions if "no_response" in str(t["flags"])}
    assert unanswered and with_message(frames, "No response in this capture") == unanswered


def test_one_pass_links_responses_back_to_requests(lua: Path, trace: Path) -> None:
    """A pipe allows one pass only: responses still name their request and its time."""
    fields = ("fw1394.request_in", "fw1394.response_time")
    two = {n: f for n, f in tshark_fields(lua, trace, *fields).items() if f}
    out = tshark(lua, trace, "-Y", "fw1394.request_in", "-T", "fields", "-e", "frame.number",
                 "-e", fields[0], "-e", fields[1])  # fmt: skip
    one = {
        int(n): {fields[0]: a, fields[1]: b}
        for n, a, b in (r.split("\t") for r in out.splitlines())
    }
    assert len(one) > 200 and one == two


def test_crc_verdicts_agree_with_fw1394(
    lua: Path, trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    packets = fw1394_json(capsys, str(trace))
    fields = ["fw1394.header_crc.valid", "fw1394.header_crc.status"]
    fields += ["fw1394.data_crc.valid", "fw1394.data_crc.status", "_ws.expert.message"]
    frames = tshark_fields(lua, trace, *fields)
    checked = 0
    for packet in packets:
        theirs = frames[int(str(packet["frame"]))]
        for crc in ("header_crc", "data_crc"):
            if f"{crc}_ok" in packet:
                good = packet[f"{crc}_ok"]
                assert theirs[f"fw1394.{crc}.valid"] == ("1" if good else "0"), packet
                assert theirs[f"fw1394.{crc}.status"] == ("1" if good else "0"), packet
                checked += 1
            else:
                assert f"fw1394.{crc}.valid" not in theirs, packet
    bad = {p["frame"] for p in packets if p.get("data_crc_ok") is False}
    assert checked > 1000 and bad and with_message(frames, "Data CRC does not match") == bad


def test_bad_header_crc_and_short_data_block_are_expert_errors(lua: Path, tmp_path: Path) -> None:
    good = encode(QuadletReadResponse(destination_id=0xFFC1, source_id=0xFFC0, tlabel=3))
    broken = bytearray(good)
    broken[-1] ^= 0x01  # the header CRC quadlet
    block = encode(BlockReadResponse(destination_id=0xFFC1, source_id=0xFFC0, data=bytes(16)))
    short = block[: 5 * 4 + 8]  # header, header CRC, half the data block
    raws = [good, bytes(broken), short]
    records = [BusRecord(i, RecordType.async_packet, raw) for i, raw in enumerate(raws)]
    path = tmp_path / "crc.pcapng"
    write_trace(str(path), records)
    fields = ("fw1394.header_crc.valid", "fw1394.header_crc.bad", "fw1394.length.bad")
    frames = tshark_fields(lua, path, *fields, "_ws.expert.severity")
    assert frames[1]["fw1394.header_crc.valid"] == "1" and "fw1394.header_crc.bad" not in frames[1]
    assert frames[2]["fw1394.header_crc.valid"] == "0" and "fw1394.header_crc.bad" in frames[2]
    assert "fw1394.length.bad" in frames[3] and "fw1394.length.bad" not in frames[2]
    assert frames[3]["fw1394.header_crc.valid"] == "1"
    errors = {n for n, f in frames.items() if str(ERROR_SEVERITY) in f["_ws.expert.severity"]}
    assert errors == {2, 3}  # all three answer nothing: a warning each, not an error


def test_source_and_destination_columns(lua: Path, trace: Path) -> None:
    columns = tshark_fields(lua, trace, "_ws.col.Source", "_ws.col.Destination")
    ids = tshark_fields(lua, trace, "fw1394.src_id", "fw1394.dst_id")
    assert sum(1 for f in ids.values() if f) > 700
    for number, f in ids.items():
        expected = {}
        if f:
            expected = {
                "_ws.col.Source": f"{int(f['fw1394.src_id'], 16):04x}",
                "_ws.col.Destination": f"{int(f['fw1394.dst_id'], 16):04x}",
            }
        assert columns[number] == expected, number


def test_offsets_print_as_48_bits(lua: Path, trace: Path) -> None:
    tree = tshark(lua, trace, "-V", "-c", "40")
    offsets = re.findall(r"^\s+offset: (\S+)", tree, re.MULTILINE)
    assert offsets and all(re.fullmatch(r"0x[0-9a-f]{12}", text) for text in offsets)
    assert "offset: 0xfffff0000400" in tree
    assert "offset=0xfffff0000400" in tshark(lua, trace, "-c", "40")  # the Info column


@pytest.mark.slow
def test_live_capture_piped_into_tshark(lua: Path, tmp_path: Path) -> None:
    """``fw1394 capture -w - | tshark -r - -X lua_script:fw1394.lua -Y ...`` on a real bus."""
    config = BusConfig(bus_name("tshark"))
    with LaunchedBus(config, 2) as bus:
        bus.wait_members()
        capture = subprocess.Popen(
            [sys.executable, "-m", "fw1394.cli.main", "capture", "--bus", config.name,
             "-w", "-", "--duration", "60"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )  # fmt: skip
        try:
            # The file header comes out as soon as the capture's tap listens.
            assert capture.stdout is not None
            head = os.read(capture.stdout.fileno(), 65536)
            with BusPort(config) as port:
                for node in (0, 1):
                    port.write_quadlet(node, 0x40, 0x1394_0000 + node)
                values = [port.read_quadlet(node, 0x40) for node in (0, 1, 0, 1)]
            capture.send_signal(signal.SIGINT)  # Ctrl-C: what it has is written
            rest, err = capture.communicate(timeout=60)
            trace = head + rest
        finally:
            if capture.poll() is None:
                capture.kill()
                capture.wait()
    assert capture.returncode == 0, err
    assert wait_until_gone(config.name) == []

    def piped(*arguments: str) -> list[list[str]]:
        command = [TSHARK or "tshark", "-X", f"lua_script:{lua}", "-r", "-", *arguments]
        result = subprocess.run(command, input=trace, capture_output=True, timeout=60)
        assert result.returncode == 0, result.stderr
        assert b"Lua Error" not in result.stdout + result.stderr
        return [line.split("\t") for line in result.stdout.decode().splitlines()]

    # Reading a pipe, tshark makes one pass: responses name their requests.
    fields = ["-T", "fields", "-e", "frame.number", "-e", "fw1394.request_in"]
    fields += ["-e", "fw1394.response_time", "-e", "fw1394.quadlet_data"]
    fields += ["-e", "_ws.col.Source", "-e", "_ws.col.Destination"]
    answers = piped("-Y", "fw1394.request_in && fw1394.tcode == 6", *fields)
    assert len(answers) >= len(values)
    assert all(value in [int(row[3], 16) for row in answers] for value in values)
    for frame, request, seconds, _, source, destination in answers:
        assert 0 < int(request) < int(frame) and 0 < float(seconds) < 1.5
        assert re.fullmatch("ffc[0-9a-f]", source) and re.fullmatch("ffc[0-9a-f]", destination)
    # The literal forward-link filter runs on the pipe too; its frames need a second pass.
    piped("-Y", "fw1394.response_in")
    saved = tmp_path / "live.pcapng"
    saved.write_bytes(trace)
    requests = tshark(lua, saved, "-2", "-Y", "fw1394.response_in", "-T", "fields",
                      "-e", "frame.number", "-e", "fw1394.response_in")  # fmt: skip
    links = {tuple(int(n) for n in line.split("\t")) for line in requests.splitlines()}
    assert {(int(row[1]), int(row[0])) for row in answers} <= links


def test_a_response_of_the_wrong_tcode_is_flagged_like_fw1394_flags_it(
    lua: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    back = 0xFFC1
    packets = [
        encode(QuadletReadRequest(destination_id=0xFFC0, source_id=back, tlabel=5, offset=0x400)),
        # A read answered with a write response:
        encode(WriteResponse(destination_id=back, source_id=0xFFC0, tlabel=5)),
        encode(QuadletReadRequest(destination_id=0xFFC0, source_id=back, tlabel=6, offset=0x404)),
        encode(QuadletReadResponse(destination_id=back, source_id=0xFFC0, tlabel=6)),
    ]
    records = [
        BusRecord(1000 * i, RecordType.async_packet, raw, ack=AckCode.ack_pending)
        for i, raw in enumerate(packets)
    ]
    path = tmp_path / "mismatch.pcapng"
    write_trace(str(path), records)
    flagged = {
        int(str(t["response_frame"]))
        for t in fw1394_json(capsys, str(path), "--transactions")
        if "tcode_mismatch" in str(t["flags"])
    }
    frames = tshark_fields(lua, path, "fw1394.request_in", "_ws.expert.message")
    assert flagged == {2} == with_message(frames, "does not answer the request")
    assert frames[2]["fw1394.request_in"] == "1" and frames[4]["fw1394.request_in"] == "3"
