"""Helpers shared by the subcommands: errors, number parsing, hex input, output."""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Iterable
from typing import Any


class CliError(Exception):
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
    """Bytes from hex that may contain spaces, newlines, ``0x`` prefixes, either case.

    Quadlets written as ``0x1f`` stand for a whole 8-digit quadlet, so tokens with a
    ``0x`` prefix are zero-filled to 8 digits; bare tokens are taken as they are.
    """
    digits = []
    for token in text.replace(",", " ").split():
        if token.lower().startswith("0x"):
            body = token[2:]
            if len(body) > 8 or not body:
                raise CliError(f"{token!r}: a 0x quadlet has 1 to 8 hex digits")
            token = body.rjust(8, "0")
        digits.append(token)
    joined = "".join(digits)
    if len(joined) % 2:
        raise CliError(f"odd number of hex digits ({len(joined)}): {text.strip()[:60]!r}")
    try:
        return bytes.fromhex(joined)
    except ValueError:
        bad = next((c for c in joined if c not in "0123456789abcdefABCDEF"), "?")
        raise CliError(f"{bad!r} is not a hex digit in {text.strip()[:60]!r}") from None


def quadlets_hex(raw: bytes) -> str:
    """Space-separated 8-digit quadlets (a shorter tail is printed as it is)."""
    return " ".join(raw[i : i + 4].hex() for i in range(0, len(raw), 4))


def print_json_lines(objects: Iterable[dict[str, Any]]) -> None:
    for obj in objects:
        print(json.dumps(obj))


def print_table(rows: Iterable[tuple[str, ...]], indent: str = "  ") -> None:
    rows = list(rows)
    if not rows:
        return
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for row in rows:
        cells = [cell.ljust(width) for cell, width in zip(row, widths, strict=True)]
        print(indent + "  ".join(cells).rstrip())
