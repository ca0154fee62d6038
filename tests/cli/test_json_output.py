"""Every ``--json`` of the command line prints through one helper.

The helper's text is pinned here against RFC 8259 as ``json.dumps`` writes it
by default (``", "`` and ``": "`` separators, non-ASCII as ``\\uXXXX``), so
moving a command onto it cannot change a byte a script reads; a grep keeps
commands from printing ``json.dumps`` themselves again.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

import fw1394
from fw1394.cli.common import print_json

CLI = Path(fw1394.__file__).parent / "cli"

_PRINTED_DUMPS = re.compile(r"print\(\s*json\.dumps\(")


def test_objects_are_one_compact_line_each(capsys: pytest.CaptureFixture[str]) -> None:
    print_json({"guid": "0x00fa610e00000003", "rom": True, "vendor": "Bü"}, {"n": [1, None]})
    assert capsys.readouterr().out == (
        '{"guid": "0x00fa610e00000003", "rom": true, "vendor": "B\\u00fc"}\n{"n": [1, null]}\n'
    )


def test_nothing_is_printed_for_no_objects(capsys: pytest.CaptureFixture[str]) -> None:
    print_json()
    assert capsys.readouterr().out == ""


@given(st.dictionaries(st.text(), st.integers() | st.text() | st.booleans() | st.none()))
def test_each_line_reads_back_as_the_object(obj: dict[str, object]) -> None:
    import contextlib
    import io

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        print_json(obj)
    text = out.getvalue()
    assert text.endswith("\n") and text.count("\n") == 1  # "\n" inside strings is escaped
    assert json.loads(text) == obj


def test_no_command_prints_json_dumps_itself() -> None:
    offenders = [
        f"{path.name}:{number}"
        for path in sorted(CLI.glob("*.py"))
        if path.name != "common.py"
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if _PRINTED_DUMPS.search(line)
    ]
    assert offenders == []
