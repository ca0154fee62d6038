"""One display-filter language: the same filters through ``dissect -Y`` and the real
``tshark -Y`` (with the generated Lua dissector) select the same frames of one trace.

The trace has retries, lost responses, unsolicited responses, acks as records of
their own, block transfers, and packets whose header or data CRC was damaged
after the fact (their pseudo-header says so, as a tap that checked them would).
"""

from __future__ import annotations

import json
import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import pytest

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views import display_filter as df
from fw1394.capture.views.lua_dissector import generate
from fw1394.cli.main import main
from fw1394.packets import (
    LAYOUTS,
    AckCode,
    QuadletWriteRequest,
    RCode,
    TCode,
    WriteResponse,
    encode,
)
from fw1394.packets.ack import ack_byte

TSHARK = shutil.which("tshark")
pytestmark = [
    pytest.mark.skipif(TSHARK is None, reason="tshark is not installed (apt-get install tshark)"),
    pytest.mark.tshark,
    pytest.mark.process,
]

#: tshark's own spellings (plain seconds for times, commas in sets) on the left of
#: the parity test; every one is run by both tools.
FILTERS = [
    "fw1394.tcode == 4",
    "fw1394.tcode in {4, 5}",
    "fw1394.tcode in {0..2}",
    "fw1394.dst_id == 0xffc0 && fw1394.tlabel < 8",
    "fw1394.src_id != 0xffc4",
    "fw1394.offset >= 0xfffff0000410",
    "fw1394.rcode != 0",
    "fw1394.data_length > 8",
    "fw1394.reserved == 0 && fw1394.tcode == 6",
    "fw1394.quadlet_data",
    "fw1394.ack == 2",
    "fw1394.response_time > 0.00001",
    "fw1394.response_time <= 0.000005",
    "fw1394.request_in",
    "fw1394.response_in",
    "!fw1394.response_in && fw1394.tcode == 4",
    "fw1394.attempts > 1",
    "fw1394.header_crc.status == 0",
    "fw1394.header_crc.status == 1 && fw1394.tcode == 1",
    "fw1394.data_crc.status == 0",
    "fw1394.header_crc.valid == 0 || fw1394.data_crc.valid == 0",
    "fw1394.data_crc",
    'fw1394.kind contains "block"',
    'fw1394.kind matches "^read_.*response$"',
    'fw1394.kind == "write_response"',
    "fw1394.data contains 0a:0b:0c",
    'fw1394.data contains "\\x14\\xaa"',
    "fw1394.ph.record_type == 2",
    "fw1394.ph.flags.crc_valid == 0",
    "fw1394.ph.sender == 0 and not fw1394.tcode == 6",
    "frame.number <= 40 or frame.number > 380",
    "frame.time_relative > 0.0001",
]


def damaged(records: list[BusRecord]) -> list[BusRecord]:
    """Every 23rd asynchronous packet with one header-CRC byte flipped, every 29th
    block packet with one data-CRC byte flipped."""
    out, seen_async, seen_block = [], 0, 0
    for record in records:
        if record.record_type == RecordType.async_packet and len(record.data) >= 16:
            seen_async += 1
            tcode = record.data[3] >> 4
            layout = LAYOUTS.get(TCode(tcode)) if tcode in set(map(int, LAYOUTS)) else None
            if layout is not None and seen_async % 23 == 0:
                at = 4 * layout.header.count
                data = bytearray(record.data)
                data[at] ^= 0x40
                record = replace(record, data=bytes(data))
            elif layout is not None and layout.has_data and len(record.data) > 24:
                seen_block += 1
                if seen_block % 29 == 0:
                    data = bytearray(record.data)
                    data[-1] ^= 0x01
                    record = replace(record, data=bytes(data))
        out.append(record)
    return out


def failed_writes(last: BusRecord) -> list[BusRecord]:
    """Quadlet writes answered with error rcodes (the simulation has none)."""
    records = []
    for index, rcode in enumerate((RCode.resp_address_error, RCode.resp_type_error)):
        at = last.timestamp_ns + 1_000 + 10_000 * index
        request = QuadletWriteRequest(
            destination_id=0xFFC1, source_id=0xFFC4, tlabel=50 + index, offset=0x10
        )
        response = WriteResponse(
            destination_id=0xFFC4, source_id=0xFFC1, tlabel=50 + index, rcode=rcode
        )
        records.append(
            BusRecord(at, RecordType.async_packet, encode(request), last.generation, sender=4)
        )
        records.append(
            BusRecord(
                at + 300, RecordType.ack, bytes([ack_byte(AckCode.ack_pending)]), last.generation
            )
        )
        records.append(
            BusRecord(at + 3_000, RecordType.async_packet, encode(response), last.generation, 1)
        )
        records.append(
            BusRecord(
                at + 3_300, RecordType.ack, bytes([ack_byte(AckCode.ack_complete)]), last.generation
            )
        )
    return records


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("parity") / "bus.pcapng"
    scenario = Scenario(busy_every=13, lost_every=17, corrupt_every=19, separate_acks=True)
    records = damaged(list(simulate(600, scenario)))
    write_trace(str(path), records + failed_writes(records[-1]))
    return path


@pytest.fixture(scope="module")
def lua(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    path.write_text(generate())
    return path


def tshark_frames(lua: Path, trace: Path, text: str) -> list[int]:
    # -2: two passes, so that a request knows its response (fw1394.response_in), as
    # Wireshark's GUI does; dissect pairs the whole trace first for the same reason.
    command = [TSHARK or "tshark", "-2", "-X", f"lua_script:{lua}", "-r", str(trace)]
    command += ["-Y", text]
    command += ["-T", "fields", "-e", "frame.number"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    return [int(line) for line in result.stdout.split()]


def dissect_frames(trace: Path, text: str, capsys: pytest.CaptureFixture[str]) -> list[int]:
    assert main(["dissect", str(trace), "-Y", text, "--json"]) == 0
    return [json.loads(line)["frame"] for line in capsys.readouterr().out.splitlines()]


@pytest.fixture(scope="module")
def frames_in_trace(lua: Path, trace: Path) -> int:
    return len(tshark_frames(lua, trace, "frame"))


@pytest.mark.parametrize("text", FILTERS)
def test_dissect_and_tshark_select_the_same_frames(
    lua: Path, trace: Path, frames_in_trace: int, text: str, capsys: pytest.CaptureFixture[str]
) -> None:
    theirs = tshark_frames(lua, trace, text)
    # A filter that selects nothing (or everything) would agree vacuously.
    assert 0 < len(theirs) < frames_in_trace, text
    ours = dissect_frames(trace, text, capsys)
    assert ours == theirs


def test_units_are_an_extension_of_tshark_seconds() -> None:
    seconds = df.parse("fw1394.response_time > 0.0002")
    units = df.parse("latency > 200us")
    assert isinstance(seconds, df.Compare) and isinstance(units, df.Compare)
    assert seconds.right == df.Literal(200_000, "0.0002")
    assert units.right == df.Literal(200_000, "200us")
