"""The generated Lua dissector, run by the real tshark, against fw1394's own dissection.

CI installs tshark from Debian (``apt-get install -y tshark``); without it the
comparison is skipped, and says why.
"""

from __future__ import annotations

import json
import shutil
import subprocess
from pathlib import Path

import pytest

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views.lua_dissector import generate
from fw1394.cli.main import main

TSHARK = shutil.which("tshark")
pytestmark = [
    pytest.mark.skipif(
        TSHARK is None, reason="tshark is not installed (Debian: apt-get install -y tshark)"
    ),
    pytest.mark.tshark,
    pytest.mark.process,
]
#: Wireshark field -> fw1394 JSON key.
FIELDS = {
    "fw1394.tcode": "tcode",
    "fw1394.tlabel": "tlabel",
    "fw1394.dst_id": "destination_id",
    "fw1394.src_id": "source_id",
    "fw1394.retry": "retry",
    "fw1394.priority": "priority",
    "fw1394.offset": "offset",
    "fw1394.rcode": "rcode",
    "fw1394.data_length": "data_length",
    "fw1394.extended_tcode": "extended_tcode",
    "fw1394.quadlet_data": "quadlet_data",
    "fw1394.header_crc": "header_crc",
}


@pytest.fixture(scope="module")
def lua(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    path.write_text(generate())
    return path


def tshark_fields(lua: Path, trace: Path) -> dict[int, dict[str, int]]:
    command = [TSHARK or "tshark", "-X", f"lua_script:{lua}", "-r", str(trace), "-T", "fields"]
    command += ["-e", "frame.number", "-e", "_ws.expert.message"]
    for field in FIELDS:
        command += ["-e", field]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "Lua Error" not in result.stdout + result.stderr
    frames = {}
    for line in result.stdout.splitlines():
        number, expert, *values = line.split("\t")
        assert "Lua Error" not in expert
        frames[int(number)] = {
            FIELDS[name]: int(value, 0) for name, value in zip(FIELDS, values, strict=True) if value
        }
    return frames


def fw1394_fields(
    trace: Path, capsys: pytest.CaptureFixture[str], *extra: str
) -> dict[int, dict[str, int]]:
    assert main(["dissect", str(trace), "--json", *extra]) == 0
    frames: dict[int, dict[str, int]] = {}
    for line in capsys.readouterr().out.splitlines():
        obj = json.loads(line)
        if "tcode" in obj:
            frames[obj["frame"]] = {
                key: obj[key] for key in FIELDS.values() if isinstance(obj.get(key), int)
            }
    return frames


def test_tshark_agrees_with_fw1394_on_a_bus_trace(
    lua: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "bus.pcapng"
    scenario = Scenario(busy_every=13, lost_every=17, corrupt_every=19, separate_acks=True)
    write_trace(str(trace), simulate(1500, scenario))
    ours = fw1394_fields(trace, capsys)
    theirs = tshark_fields(lua, trace)
    assert len(ours) > 700
    for frame, fields in ours.items():
        assert theirs[frame] == fields, frame
    # Frames fw1394 does not call asynchronous packets carry no packet fields in Wireshark.
    assert all(not fields for frame, fields in theirs.items() if frame not in ours)


def test_tshark_agrees_on_eth1394_udp(
    lua: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    trace = tmp_path / "eth.pcap"
    write_eth1394_sample(str(trace))
    ours = fw1394_fields(trace, capsys)
    theirs = tshark_fields(lua, trace)
    # The FPGA's zero CRC quadlets: Wireshark shows the zeros, fw1394 shows "not computed".
    for frame in (2, 4):
        assert theirs[frame].pop("header_crc") == 0 and "header_crc" not in ours[frame]
    assert len(ours) == 6 and theirs == ours


def test_tshark_reads_the_pseudo_header(lua: Path, tmp_path: Path) -> None:
    trace = tmp_path / "small.pcapng"
    write_trace(str(trace), simulate(20))
    command = [TSHARK or "tshark", "-X", f"lua_script:{lua}", "-r", str(trace), "-T", "fields"]
    command += ["-e", "fw1394.ph.record_type", "-e", "fw1394.ph.generation", "-e", "fw1394.ph.ack"]
    command += ["-e", "fw1394.ph.flags.crc_present", "-e", "fw1394.phy.phy_id"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    rows = [line.split("\t") for line in result.stdout.splitlines()]
    assert rows[0][:2] == ["3", "2"]  # the bus reset that opens the trace, generation 2
    assert [row[4] for row in rows[1:6]] == ["0", "1", "2", "3", "4"]  # its self-IDs
    assert rows[6][0] == "0" and rows[6][2] == "2" and rows[6][3] == "1"
