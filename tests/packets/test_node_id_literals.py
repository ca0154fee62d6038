"""Node IDs are built and taken apart only through :mod:`fw1394.packets.nodeid`.

IEEE 1394-1995 6.2.4.2: a node ID is a 10-bit bus ID over a 6-bit physical ID;
physical ID 63 broadcasts and bus 0x3FF is the local bus, so the local bus's
node IDs are 0xFFC0 | phy. Code that writes those facts as numbers
(``63``, ``0x3F``, ``& 0x3F``, ``>> 6``, ``0xFFC0``) restates them; this
check reads the code tokens of every module (docstrings, other strings and
comments are prose) and lists who still does.

A literal that means something else on its line (a tlabel or a gap count,
whose largest value is also 63) says so with a ``# not a node ID`` comment.
Board data (register maps of a board's own firmware) is listed in ``ALLOWED``.
"""

from __future__ import annotations

import io
import re
import tokenize
from pathlib import Path

import pytest

import fw1394

ROOT = Path(fw1394.__file__).parent

#: Modules (relative to fw1394/) that may still hold node-ID literals, with why.
ALLOWED: dict[str, str] = {
    "packets/nodeid.py": "the vocabulary itself",
    # Board data: fields of a board's own registers that happen to be 6 bits wide.
    "boards/qla1/phy_window.py": "board data",
    "boards/qla1/rt_blocks.py": "board data",
    "boards/snake2010/global_io.py": "board data",
}

_LOCAL_NODE_ID = re.compile(r"0x[fF]{2}[cC][0-9a-fA-F]$")
_MARK = "not a node ID"


def literals(source: str) -> list[tuple[int, str]]:
    """``(line, token)`` of each node-ID literal in the code of ``source``."""
    found = []
    tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    lines = source.splitlines()
    for index, token in enumerate(tokens):
        if token.type != tokenize.NUMBER:
            continue
        before = tokens[index - 1].string if index else ""
        text = token.string
        try:  # an octal 0o077 is a file mode, a float or complex no ID at all
            value = None if text[:2].lower() == "0o" else int(text.replace("_", ""), 0)
        except ValueError:
            value = None
        node_literal = (
            (value == 63 and before != "**")  # 2**63 is a bound, not a node
            or _LOCAL_NODE_ID.match(text) is not None
            or (value == 6 and before == ">>")
        )
        if node_literal and _MARK not in lines[token.start[0] - 1]:
            found.append((token.start[0], f"{before} {text}".strip()))
    return found


def test_no_node_id_literal_outside_the_vocabulary_and_the_allowed() -> None:
    offenders = [
        f"{path.relative_to(ROOT)}:{line}: {text}"
        for path in sorted(ROOT.rglob("*.py"))
        if str(path.relative_to(ROOT)) not in ALLOWED
        for line, text in literals(path.read_text())
    ]
    assert offenders == []


@pytest.mark.parametrize("name", sorted(set(ALLOWED) - {"packets/nodeid.py"}))
def test_each_allowed_module_still_needs_it(name: str) -> None:
    assert literals((ROOT / name).read_text()), f"fw1394/{name} has none now: take it off"


def test_the_check_sees_the_literals_and_not_the_prose() -> None:
    source = (
        '"""Physical ID 63 broadcasts; 0xFFC0 is node 0."""\n'
        "phy = node_id & 0x3F\n"
        "bus = node_id >> 6\n"
        "base = 0xFFC2\n"
        "broadcast = 63\n"
        "other = 0x3f\n"
        "tlabel = 63  # not a node ID: the highest tlabel\n"
        "limit = 2**63 - 1\n"
        "mode = stat & 0o077\n"
        "speed = value >> 2\n"
        "text = 'node 63'  # 63 in a comment\n"
    )
    assert literals(source) == [
        (2, "& 0x3F"),
        (3, ">> 6"),
        (4, "= 0xFFC2"),
        (5, "= 63"),
        (6, "= 0x3f"),
    ]
