"""Generated code is compiled in one module, and a traceback shows its lines.

The codecs, field readers and the engine's common turns are generated at import
time. A failure inside one must point at the generated line that ran, as it
would in a file, rather than at ``File "<string>", line 1``; and no module but
:mod:`fw1394.packets.codegen` may call ``exec`` or ``eval``.
"""

from __future__ import annotations

import inspect
import linecache
import re
import traceback
from pathlib import Path

import pytest

import fw1394
from fw1394.packets.accessors import TLABEL
from fw1394.packets.codegen import compile_function
from fw1394.packets.fields import Quadlets

PACKAGE = Path(fw1394.__file__).parent
CALLS = re.compile(r"\b(exec|eval)\s*\(")


def test_a_traceback_from_a_generated_reader_shows_the_generated_line() -> None:
    # The transaction label is bits 7-2 of the header's third byte (IEEE 1394
    # asynchronous header, quadlet 0 bits 15-10): its reader indexes byte 2, and
    # an empty buffer fails right there.
    with pytest.raises(IndexError) as raised:
        TLABEL.of_bytes(b"")
    last = traceback.extract_tb(raised.value.__traceback__)[-1]
    assert last.filename.startswith("<fw1394-generated fw1394.packets.accessors tlabel")
    assert last.lineno == 2
    assert last.line is not None
    assert "data[offset + 2]" in last.line
    assert ">> 2" in last.line


def test_a_generated_function_has_its_own_file_and_readable_source() -> None:
    source = ["def halve(value):", "    checked = value + 0", "    return checked // 2"]
    halve = compile_function(source, {}, "halve", origin="test halve")
    twin = compile_function(source, {}, "halve", origin="test halve")
    assert halve(9) == 4
    filename = halve.__code__.co_filename
    assert filename != twin.__code__.co_filename  # one file name per function
    assert linecache.getline(filename, 3) == "    return checked // 2\n"
    assert inspect.getsource(halve).splitlines() == source
    with pytest.raises(TypeError) as raised:
        halve("nine")
    formatted = "".join(traceback.format_exception(raised.value))
    assert f'File "{filename}", line 2, in halve' in formatted
    assert "checked = value + 0" in formatted


def test_linecache_checks_keep_the_generated_source() -> None:
    layout = Quadlets([("high", 16), ("low", 16)])
    filename = layout.unpack_values.__code__.co_filename
    linecache.checkcache()  # what a debugger does before it shows a frame
    assert "unpack_from" in linecache.getline(filename, 2)
    assert layout.unpack_values(bytes([0x12, 0x34, 0x56, 0x78])) == (0x1234, 0x5678)


def test_only_the_generator_calls_exec_or_eval() -> None:
    generator = PACKAGE / "packets" / "codegen.py"
    found = [
        f"{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path != generator
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if CALLS.search(line)
    ]
    assert found == []
    assert CALLS.search(generator.read_text())  # the check would see a call
