"""Register tables in ``docs/boards/*.md``, written from the register maps.

A table sits between two comments naming the board kind, the register group,
the index column's header and, optionally, a prefix for the index (``c`` for
channel registers, printed ``c0``, ``c1``, ...)::

    <!-- registers qla1 board Idx -->
    | Idx | Name | ... generated ... |
    <!-- end registers -->

``python -m fw1394.boards.regdocs docs/boards/*.md`` rewrites the tables in
place; the test suite fails while a document and its map disagree.
"""

from __future__ import annotations

import re
import sys
from pathlib import Path

from fw1394.boards.registry import board_kind
from fw1394.boards.regmap import markdown_table
from fw1394.errors import UsageError

_BLOCK = re.compile(
    r"(?P<open><!-- registers (?P<kind>\S+) (?P<group>\S+) (?P<header>\S+)"
    r"(?: (?P<prefix>\S+))? -->\n)(?P<table>.*?)(?P<close><!-- end registers -->)",
    re.DOTALL,
)


class RegisterDocError(UsageError):
    """A marked table names a kind or group the registry does not have."""


def render(text: str) -> str:
    """``text`` with every marked register table written from its map."""

    def table(match: re.Match[str]) -> str:
        try:
            registers = board_kind(match["kind"]).registers
            if registers is None:
                raise KeyError(f"board kind {match['kind']!r} has no register map")
            group = registers.group(match["group"])
        except KeyError as error:
            raise RegisterDocError(str(error.args[0])) from None
        body = markdown_table(group, match["header"], match["prefix"] or "")
        return f"{match['open']}{body}\n{match['close']}"

    return _BLOCK.sub(table, text)


def tables(text: str) -> int:
    """How many marked tables ``text`` holds."""
    return len(_BLOCK.findall(text))


USAGE = "usage: python -m fw1394.boards.regdocs FILE.md ... (for instance docs/boards/*.md)"


def main(paths: list[str]) -> int:
    if not paths:
        print(f"regdocs: no document named; {USAGE}", file=sys.stderr)
        return 2
    for name in paths:
        path = Path(name)
        try:
            text = path.read_text(encoding="utf-8")
        except (OSError, UnicodeDecodeError) as error:
            print(f"regdocs: {name}: cannot read it ({error})", file=sys.stderr)
            return 2
        try:
            new = render(text)
        except RegisterDocError as error:
            print(f"{name}: {error}", file=sys.stderr)
            return 2
        count = tables(text)
        if not count:
            print(f"{name}: no register tables (marked <!-- registers KIND GROUP HEADER -->)")
        elif new != text:
            path.write_text(new, encoding="utf-8")
            print(f"{name}: register tables rewritten ({count})")
        else:
            print(f"{name}: {count} register tables already match their maps")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
