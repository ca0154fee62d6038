"""``fw1394 demo``: the built-in tour (the README's first command)."""

from __future__ import annotations

import argparse
from typing import Any

from fw1394.cli.common import print_table
from fw1394.packets import decode, field_rows, summary

#: Packets a real JHU host sent to a board, and a board's answer (spec captures).
EXAMPLES = (
    ("host reads HW_VERSION of node 0", "ffc01c40 ffd00000 00000004 a9927b79"),
    ("board answers 'QLA1'", "ffd01c60 ffc00000 00000000 514c4131 2428f807"),
    (
        "host writes the real-time block",
        "ffc0a010 ffd00000 00000000 00180000 48855894 00000006 80008000 80008000 "
        "80008000 80008000 00000000 c4d5d450",
    ),
    ("a self-ID packet", "80458c80 7fba737f"),
)


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="a guided tour on built-in examples",
        description="Decode example packets captured from real JHU host software.",
    )
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    for title, text in EXAMPLES:
        packet = decode(bytes.fromhex(text.replace(" ", "")))
        print(f"# {title}\n{text}\n{summary(packet)}")
        print_table(field_rows(packet))
        print()
    return 0
