"""``fw1394 encode`` / ``fw1394 decode`` as a user runs them: a real process each time."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from fw1394.cli.main import main
from fw1394.packets import LAYOUTS, PHY_CLASSES

QREAD = "ffc0f140 ffc1ffff f0000984 5bdd119c"


def fw1394(*args: str, stdin: str | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", *args],
        input=stdin,
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.process
def test_decode_arguments_prints_summary_and_table() -> None:
    result = fw1394("decode", *QREAD.split())
    assert result.returncode == 0, result.stderr
    first, *table = result.stdout.splitlines()
    assert first.startswith("read_quadlet_request ffc1 -> ffc0 tl=60")
    assert any(line.split()[:2] == ["offset", "0xfffff0000984"] for line in table)


@pytest.mark.process
def test_decode_json_has_the_documented_keys() -> None:
    result = fw1394("decode", "--json", *QREAD.upper().replace("FF", "ff").split())
    obj = json.loads(result.stdout)
    assert list(obj) == [
        "tcode",
        "tcode_name",
        "destination_id",
        "tlabel",
        "retry",
        "priority",
        "source_id",
        "offset",
        "header_crc",
        "header_crc_ok",
    ]
    assert obj["offset"] == 0xFFFFF0000984 and obj["header_crc_ok"] is True


@pytest.mark.process
def test_decode_block_json_keys() -> None:
    packet = "ffc06c10 ffd00000 00002000 000c0000 cca946ca 00000011 00000022 00000033 54289f99"
    obj = json.loads(fw1394("decode", "--json", packet).stdout)
    assert obj["data"] == "000000110000002200000033"
    assert obj["data_length"] == 12 and obj["data_crc_ok"] is True and obj["extended_tcode"] == 0


@pytest.mark.process
def test_decode_stdin_tolerates_0x_case_and_spacing_and_reports_bad_lines() -> None:
    stdin = "0xFFC0F140 0xFFC1FFFF\n  0xF0000984 0x5BDD119C\n" + "\n" + "ffc0f140 12\n" + "abc\n"
    result = fw1394("decode", "--json", stdin=stdin)
    # Each line is one packet: the first two lines are two (bad) packets here.
    assert result.returncode == 2
    errors = result.stderr.strip().splitlines()
    assert all(line.startswith("fw1394: error: line ") for line in errors)
    assert any("odd number of hex digits" in line for line in errors)
    assert "Traceback" not in result.stderr


@pytest.mark.process
def test_decode_stdin_one_packet_per_line() -> None:
    stdin = f"{QREAD}\n# a comment\n80458c80 7fba737f\n"
    result = fw1394("decode", "--json", stdin=stdin)
    assert result.returncode == 0, result.stderr
    objs = [json.loads(line) for line in result.stdout.splitlines()]
    assert objs[0]["tcode"] == 4
    assert objs[1]["kind"] == "self_id" and objs[1]["gap_count"] == 5


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["ffc0f140", "ffc1ffff", "f0000984", "5bdd1190"], "header_crc"),
        (["ffc0f14"], "odd number of hex digits"),
        (["ffc0"], "shorter than one quadlet"),
        (["ffc0f1f0", "ffc1ffff", "f0000984", "5bdd119c"], "tcode: 0xf"),
        (["ffc0f150", "ffc1ffff", "f0000984"], "too short"),
        (["zz"], "not a hex digit"),
    ],
)
@pytest.mark.process
def test_decode_bad_input_is_one_line_and_exit_2(args: list[str], message: str) -> None:
    result = fw1394("decode", *args)
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1
    assert message in result.stderr


@pytest.mark.process
def test_decode_lenient_shows_the_problem() -> None:
    result = fw1394("decode", "--lenient", "--json", "ffc0f140", "ffc1ffff", "f0000984", "5bdd1190")
    obj = json.loads(result.stdout)
    assert result.returncode == 0
    assert obj["header_crc_ok"] is False and "header_crc" in obj["problems"][0]


@pytest.mark.process
def test_decode_no_crc_reports_crc_absent() -> None:
    obj = json.loads(fw1394("decode", "--no-crc", "--json", "ffc0f140 ffc1ffff f0000984").stdout)
    assert obj["header_crc"] is None and obj["header_crc_ok"] is None


@pytest.mark.process
def test_encode_matches_the_kernel_vector() -> None:
    result = fw1394(
        "encode",
        "read_quadlet_request",
        "--destination-id",
        "0xffc0",
        "--tlabel",
        "60",
        "--retry",
        "1",
        "--source-id",
        "0xffc1",
        "--offset",
        "0xfffff0000984",
    )
    assert result.stdout.strip() == QREAD


@pytest.mark.process
def test_encode_block_write_matches_the_captured_jhu_datagram() -> None:
    result = fw1394(
        "encode",
        "write_block_request",
        "--destination-id",
        "0xffc0",
        "--source-id",
        "0xffd0",
        "--tlabel",
        "27",
        "--offset",
        "0x2000",
        "--data",
        "00000011 00000022 00000033",
    )
    assert result.stdout.strip() == (
        "ffc06c10 ffd00000 00002000 000c0000 cca946ca 00000011 00000022 00000033 54289f99"
    )


KINDS = [
    *(layout.name for layout in LAYOUTS.values()),
    *(cls.NAME for cls in PHY_CLASSES),
    "ack",
]


@pytest.mark.parametrize("kind", KINDS)
def test_encode_then_decode_every_kind(kind: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["encode", kind]) == 0
    encoded = capsys.readouterr().out.split()
    assert main(["decode", "--json", *encoded]) == 0, capsys.readouterr().err
    obj = json.loads(capsys.readouterr().out)
    assert obj.get("tcode_name", obj.get("kind")) == kind


@pytest.mark.process
def test_encode_out_of_range_field_is_one_line() -> None:
    result = fw1394("encode", "read_quadlet_request", "--tlabel", "64")
    assert result.returncode == 2
    assert result.stderr.strip() == (
        "fw1394 encode read_quadlet_request: error: argument --tlabel: "
        "64 (0x40) does not fit in 6 bits (0..0x3f) (see fw1394 encode read_quadlet_request --help)"
    )


@pytest.mark.process
def test_encode_help_lists_fields() -> None:
    text = fw1394("encode", "lock_request", "--help").stdout
    for option in ("--destination-id", "--tlabel", "--offset", "--extended-tcode", "--data"):
        assert option in text
