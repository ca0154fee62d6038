"""Helpers shared by the subcommands: errors, number parsing, hex input, output."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable
from typing import Any

from fw1394.errors import UsageError
from fw1394.packets import hextext


class CliError(UsageError):
    """A problem with the user's input or environment, printed as one line."""


def fail(message: str, status: int = 2) -> int:
    print(f"fw1394: error: {message}", file=sys.stderr)
    return status


def integer(text: str) -> int:
    """argparse type: decimal, 0x hex, 0o octal or 0b binary; underscores allowed."""
    try:
        return int(text.replace("_", ""), 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (use 123 or 0x7b)") from None


def hex_bytes(text: str) -> bytes:
    """:func:`fw1394.packets.hextext.hex_bytes`, its error as a one-line :class:`CliError`."""
    try:
        return hextext.hex_bytes(text)
    except hextext.HexTextError as error:
        raise CliError(str(error)) from None


def print_json_lines(objects: Iterable[dict[str, Any]]) -> None:
    for obj in objects:
        print(json.dumps(obj))


def print_table(rows: Iterable[tuple[str, ...]], indent: str = "  ") -> None:
    """Rows in aligned columns: plain text for pipes and files, rich's grid on a terminal
    (which measures wide characters and wraps the last column to the window)."""
    rows = list(rows)
    if not rows:
        return
    if sys.stdout.isatty():
        _print_grid(rows, indent)
        return
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        cells = [cell.ljust(width) for cell, width in zip(row, widths, strict=True)]
        print(indent + "  ".join(cells).rstrip())


def _print_grid(rows: list[tuple[str, ...]], indent: str) -> None:
    from rich.console import Console
    from rich.padding import Padding
    from rich.table import Table
    from rich.text import Text

    grid = Table.grid(padding=(0, 2))
    for _ in rows[0]:
        grid.add_column()
    for row in rows:
        grid.add_row(*(Text(cell) for cell in row))  # cells are data, not rich markup
    Console(file=sys.stdout, highlight=False).print(Padding(grid, (0, 0, 0, len(indent))))
