"""Ack bytes and PHY packet kinds in the Lua dissector: read with rows generated from the layouts.

Run by the real tshark and compared with fw1394's own codec, for every ack
byte and for PHY packets of every kind the fuzzer's strategies produce.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views.lua_dissector import generate
from fw1394.fuzz.strategies import phy_packets
from fw1394.packets import Ack, PhyPacket, decode, encode

TSHARK = shutil.which("tshark")
pytestmark = pytest.mark.skipif(
    TSHARK is None, reason="tshark is not installed (Debian: apt-get install -y tshark)"
)


@pytest.fixture(scope="module")
def lua(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    path.write_text(generate())
    return path


def tshark_rows(lua: Path, trace: Path, *fields: str) -> list[list[str]]:
    command = [TSHARK or "tshark", "-X", f"lua_script:{lua}", "-r", str(trace), "-T", "fields"]
    for field in fields:
        command += ["-e", field]
    result = subprocess.run(command, capture_output=True, text=True, timeout=60)
    assert result.returncode == 0, result.stderr
    assert "Lua Error" not in result.stdout + result.stderr
    return [line.split("\t") for line in result.stdout.splitlines()]


@pytest.mark.process
def test_every_ack_byte(lua: Path, tmp_path: Path) -> None:
    trace = tmp_path / "acks.pcapng"
    records = [BusRecord(i, RecordType.ack, bytes([i])) for i in range(256)]
    write_trace(str(trace), records)
    rows = tshark_rows(lua, trace, "fw1394.ack", "fw1394.ack_parity")
    assert len(rows) == 256
    for byte, (code, parity) in enumerate(rows):
        ack = decode(bytes([byte]), kind="ack", strict=False)
        assert isinstance(ack, Ack)
        assert (int(code), int(parity, 16)) == (ack.code, ack.parity), byte


@settings(
    max_examples=5, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture]
)
@given(st.lists(phy_packets(), min_size=20, max_size=40))
@pytest.mark.process
def test_phy_packet_kinds(lua: Path, tmp_path: Path, packets: list[PhyPacket]) -> None:
    trace = tmp_path / "phy.pcapng"
    raws = [encode(packet) for packet in packets]
    records = [BusRecord(i, RecordType.phy_packet, raw) for i, raw in enumerate(raws)]
    write_trace(str(trace), records)
    rows = tshark_rows(lua, trace, "fw1394.phy.kind")
    assert [row[0] for row in rows] == [decode(raw, kind="phy").kind for raw in raws]
