"""``fw1394 encode``: help that lists fields, value names accepted, JSON only with --json."""

from __future__ import annotations

import dataclasses
import json

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.cli.codec import FIELD_ENUMS, _field_widths, _kind_name
from fw1394.cli.main import main
from fw1394.packets import (
    ASYNC_CLASSES,
    PHY_CLASSES,
    Ack,
    AckCode,
    RCode,
    WriteResponse,
    encode,
)
from fw1394.packets.hextext import quadlets_hex

KINDS = [(_kind_name(cls), cls) for cls in (*ASYNC_CLASSES.values(), *PHY_CLASSES, Ack)]


def run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    try:
        status = main(list(argv))
    except SystemExit as done:
        status = int(done.code or 0)
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_encode_help_lists_kinds_without_dataclass_reprs(
    capsys: pytest.CaptureFixture[str],
) -> None:
    status, out, _ = run(capsys, "encode", "--help")
    assert status == 0
    assert "(*," not in out and "None =" not in out
    for name, _ in KINDS:
        assert f"    {name}" in out
    assert "read one quadlet (tcode 0x4)" in out


@pytest.mark.parametrize(("name", "cls"), KINDS, ids=[n for n, _ in KINDS])
def test_kind_help_lists_every_field_with_its_width(
    name: str, cls: type, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, _ = run(capsys, "encode", name, "--help")
    assert status == 0 and "(*," not in out
    text = " ".join(out.split())
    widths = _field_widths(cls)
    for field in dataclasses.fields(cls):
        option = "--" + field.name.replace("_", "-")
        if field.name == "trailing" or option not in text:
            continue
        if field.type == "int" or field.name in ("header_crc", "data_crc", "inverse", "parity"):
            assert f"{option} " in text
            if field.name in widths:
                assert f"{widths[field.name]} bits: " in text, (name, field.name)
        enum = FIELD_ENUMS.get(field.name)
        if enum is not None:
            for member in enum:
                assert f"{int(member)} {member.name}" in text, (name, field.name, member)


def test_value_names_and_numbers_make_the_same_packet(capsys: pytest.CaptureFixture[str]) -> None:
    by_name = run(
        capsys, "encode", "write_response", "--rcode", "resp_address_error", "--tlabel", "5"
    )
    by_number = run(capsys, "encode", "write_response", "--rcode", "7", "--tlabel", "5")
    truth = quadlets_hex(encode(WriteResponse(rcode=RCode.resp_address_error, tlabel=5)))
    assert by_name == by_number == (0, truth + "\n", "")
    status, out, _ = run(capsys, "encode", "ack", "--code", "ack_busy_A")
    assert status == 0 and out.strip() == encode(Ack(AckCode.ack_busy_A)).hex()


def test_json_is_json_only(capsys: pytest.CaptureFixture[str]) -> None:
    status, plain, _ = run(capsys, "encode", "read_quadlet_request", "--offset", "0xfffff0000400")
    status_json, out, err = run(
        capsys, "encode", "read_quadlet_request", "--offset", "0xfffff0000400", "--json"
    )
    assert status == status_json == 0 and err == ""
    (line,) = out.splitlines()
    obj = json.loads(line)
    assert obj["hex"] == plain.strip() and obj["offset"] == 0xFFFFF0000400
    assert obj["tcode_name"] == "read_quadlet_request"


@pytest.mark.parametrize(
    ("argv", "field"),
    [
        (["ack", "--parity", "99"], "--parity"),
        (["ack", "--code", "16"], "--code"),
        (["read_quadlet_request", "--destination-id", "0x10000"], "--destination-id"),
        (["read_quadlet_request", "--offset", str(1 << 48)], "--offset"),
        (["self_id", "--gap-count", "64"], "--gap-count"),
        (["write_response", "--rcode", "complete"], "--rcode"),
    ],
)
def test_out_of_range_values_blame_their_field(
    argv: list[str], field: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(capsys, "encode", *argv)
    assert status == 2 and out == ""
    (line,) = err.splitlines()
    assert f"argument {field}:" in line


@settings(max_examples=40, deadline=None)
@given(
    tlabel=st.integers(0, 63),
    rcode=st.sampled_from(list(RCode)),
    named=st.booleans(),
)
def test_cli_encoding_equals_the_codec(tlabel: int, rcode: RCode, named: bool) -> None:
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        status = main(
            ["encode", "write_response", "--tlabel", str(tlabel),
             "--rcode", rcode.name if named else str(int(rcode))]
        )  # fmt: skip
    assert status == 0
    assert out.getvalue().strip() == quadlets_hex(encode(WriteResponse(tlabel=tlabel, rcode=rcode)))
