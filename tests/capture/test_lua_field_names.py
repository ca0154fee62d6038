"""``dissect -Y`` and the Wireshark dissector name fields alike.

The Lua field list comes from the real tshark (``tshark -G fields`` with the
generated dissector loaded), so a field counts only if Wireshark registered it.
"""

from __future__ import annotations

import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views.display_filter import ALIASES, FIELDS, PREFIX, field_name
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
#: -Y fields that Wireshark itself provides for every frame.
WIRESHARK_OWN = {"frame": "frame.number", "time": "frame.time_relative"}
#: Lua fields with no -Y counterpart, and why.
LUA_ONLY = {
    r"fw1394\.phy\.(?!check).*": "PHY packets' own fields: dissect -v shows them",
    r"fw1394\.(.*\.bad|.*\.error|malformed|response\.(missing|unmatched|tcode_mismatch))": (
        "expert info"
    ),
}


@pytest.fixture(scope="module")
def lua_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    lua = tmp_path_factory.mktemp("lua") / "fw1394.lua"
    lua.write_text(generate())
    return lua


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """Acks in the pseudo-header (no ack records), busy acks, lost and corrupted packets."""
    path = tmp_path_factory.mktemp("trace") / "bus.pcapng"
    write_trace(str(path), simulate(600, Scenario(busy_every=7, lost_every=11, corrupt_every=13)))
    return path


@pytest.fixture(scope="module")
def registered(lua_file: Path) -> set[str]:
    command = [TSHARK or "tshark", "-G", "fields", "-X", f"lua_script:{lua_file}"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    rows = [line.split("\t") for line in result.stdout.splitlines()]
    return {row[2] for row in rows if len(row) > 2 and row[0] == "F"}


def test_every_display_filter_field_is_a_wireshark_field(registered: set[str]) -> None:
    for name in FIELDS:
        if name in WIRESHARK_OWN:
            assert WIRESHARK_OWN[name] in registered
            continue
        spellings = [name, *(alias for alias, target in ALIASES.items() if target == name)]
        found = [PREFIX + s for s in spellings if PREFIX + s in registered]
        assert found, f"-Y field {name} is not in the Lua dissector under {spellings}"
        assert all(field_name(spelling) == name for spelling in found)


def test_every_lua_field_is_a_display_filter_field_or_explained(registered: set[str]) -> None:
    ours = {name for name in registered if name.startswith(PREFIX)}
    unfiltered = {name for name in ours if field_name(name) is None}
    assert len(ours) - len(unfiltered) >= len(FIELDS) - len(WIRESHARK_OWN)
    for name in unfiltered:
        assert any(re.fullmatch(pattern, name) for pattern in LUA_ONLY), name
    for pattern in LUA_ONLY:
        assert any(re.fullmatch(pattern, name) for name in unfiltered), f"stale: {pattern}"


@pytest.mark.parametrize(
    "expression",
    [
        "fw1394.tcode == 4",
        "fw1394.ack == 2",
        "fw1394.ack == 16 || fw1394.ack == 4",
        "fw1394.src_id == 0xffc4 && fw1394.tlabel < 10",
        "fw1394.rcode == 0 && fw1394.tcode != 2",
        "fw1394.offset == 0xfffff0000400",
        "fw1394.ph.generation == 2 && fw1394.data_length >= 16",
        "fw1394.dst_id == 0xffc0 || !(fw1394.quadlet_data)",
        "fw1394.ph.speed == 2 && fw1394.ph.record_type == 0 && fw1394.ph.sender < 3",
    ],
)
def test_one_filter_selects_the_same_frames_in_both(
    expression: str, lua_file: Path, trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(["dissect", str(trace), "-Y", expression, "--json"]) == 0
    ours = [json.loads(line)["frame"] for line in capsys.readouterr().out.splitlines()]
    command = [TSHARK or "tshark", "-X", f"lua_script:{lua_file}", "-r", str(trace)]
    command += ["-Y", expression, "-T", "fields", "-e", "frame.number"]
    result = subprocess.run(command, capture_output=True, text=True, timeout=120)
    assert result.returncode == 0, result.stderr
    theirs = [int(n) for n in result.stdout.split()]
    assert ours and ours == theirs
