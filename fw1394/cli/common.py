"""Helpers shared by the subcommands: errors, number parsing, hex input, output."""

from __future__ import annotations

import argparse
import errno
import json
import os
import sys
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from typing import Any

from fw1394.errors import UsageError


class CliError(UsageError):
    """A problem with the user's input or environment, printed as one line."""


def fail(message: str, status: int = 2) -> int:
    print(f"fw1394: error: {message}", file=sys.stderr)
    return status


#: Errors of a write that no retry will fix: the reader went away, or the file
#: system cannot take more.
WRITE_ERRNOS = frozenset({errno.EPIPE, errno.ENOSPC, errno.EFBIG, errno.EDQUOT, errno.EIO})


@contextmanager
def reported_write_errors() -> Iterator[None]:
    """Flush standard output at the end of a command (also of ``--help``, which
    exits), so that a failed write (``> /dev/full``, a full disk under ``-w``) is
    the command's one-line :class:`CliError` rather than a traceback or an
    ``Exception ignored`` at interpreter exit. A reader that closed the pipe
    (``| head``) ends the command quietly: a BrokenPipeError for main()."""
    try:
        try:
            yield
        except SystemExit:
            sys.stdout.flush()
            raise
        sys.stdout.flush()
    except OSError as error:
        if error.errno not in WRITE_ERRNOS:
            raise
        _discard_stdout()
        target = error.filename if error.filename else "standard output"
        if error.errno == errno.EPIPE and not error.filename:
            # The reader went away (| head): ending quietly is what it asked for,
            # as tshark and the shell's own tools do.
            raise BrokenPipeError(errno.EPIPE, "broken pipe") from None
        raise CliError(f"cannot write {target}: {os.strerror(error.errno)}") from None


def _discard_stdout() -> None:
    """Point standard output at /dev/null, so that what is still buffered for it
    is dropped at exit instead of failing a second time."""
    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        os.close(devnull)
    except (OSError, ValueError):  # no file descriptor behind it (a test's StringIO)
        pass


def integer(text: str) -> int:
    """argparse type: decimal, 0x hex, 0o octal or 0b binary; underscores allowed."""
    try:
        return int(text.replace("_", ""), 0)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a number (use 123 or 0x7b)") from None


def print_json(*objects: Any) -> None:
    """Each object as one line of compact JSON on standard output (JSON Lines).

    Every ``--json`` of the command line prints through here, so every one
    writes the same text for the same object: ``json.dumps``'s default
    separators, non-ASCII escaped, one ``\\n`` after each object."""
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
