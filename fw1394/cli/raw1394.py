"""``fw1394 run`` and ``fw1394 libraw1394``: real libraw1394 programs on a virtual bus.

``run`` starts a program with fw1394's ``libraw1394.so.11`` first on its library
search path and the bus named as its first port, so ``testlibraw``, the JHU
host library's FireWire programs or anything else linked against libraw1394
drives the bus through its host adapter. ``libraw1394 --path`` prints where the
library is, for setting ``LD_LIBRARY_PATH`` by hand.
"""

from __future__ import annotations

import argparse
import os
import shutil
from typing import Any

from fw1394.cli.common import CliError, print_json
from fw1394.transport.sansio.config import DEFAULT_BUS

RUN_EPILOG = """\
examples:
  fw1394 bus up --name rig --nodes 2 --board qla1
  fw1394 run --name rig -- testlibraw
  fw1394 run --name rig -- dumpiso -c 5 dump.iso

The program sees bus RIG as port 0 (other buses of this user follow); its
local node is the bus's host adapter. Set FW1394_BUS and FW1394_ADAPTER and
LD_LIBRARY_PATH yourself (see `fw1394 libraw1394`) to do the same by hand.
"""

LIBRARY_EPILOG = """\
examples:
  fw1394 libraw1394 --path
  LD_LIBRARY_PATH=$(dirname $(fw1394 libraw1394 --path)) FW1394_BUS=rig testlibraw

The library is compiled from fw1394's C source with the system compiler on
first use (gcc and Debian's libraw1394-dev headers) into ~/.cache/fw1394.
"""


def register(subparsers: Any) -> None:
    run_parser = subparsers.add_parser(
        "run",
        help="run a libraw1394 program against a virtual bus",
        description="Run PROGRAM with fw1394's libraw1394.so.11 in place of the system's, "
        "talking to bus NAME through its host adapter.",
        epilog=RUN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    run_parser.add_argument("--name", default=DEFAULT_BUS, help="bus name (default: %(default)s)")
    run_parser.add_argument("command", nargs=argparse.REMAINDER, metavar="-- PROGRAM ARGS")
    run_parser.set_defaults(handler=run)
    library_parser = subparsers.add_parser(
        "libraw1394",
        help="where fw1394's libraw1394.so.11 is (built on first use)",
        description="Build (once) and locate fw1394's drop-in libraw1394.so.11.",
        epilog=LIBRARY_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    library_parser.add_argument("--path", action="store_true", help="print only the path")
    library_parser.add_argument("--json", action="store_true", help="one JSON object")
    library_parser.set_defaults(handler=library)


def library(args: argparse.Namespace) -> int:
    from fw1394.raw1394.build import library_path

    path = str(library_path())
    if args.path:
        print(path)
    elif args.json:
        print_json({"path": path, "directory": os.path.dirname(path)})
    else:
        print(f"libraw1394.so.11: {path}")
        print(f"use: LD_LIBRARY_PATH={os.path.dirname(path)} FW1394_BUS=NAME PROGRAM")
    return 0


def run(args: argparse.Namespace) -> int:
    from fw1394.raw1394.launch import ADAPTER_VARIABLE, environment

    command = list(args.command)
    if command and command[0] == "--":
        command = command[1:]
    if not command:
        raise CliError("no program to run: fw1394 run --name BUS -- PROGRAM ARGS")
    program = shutil.which(command[0])
    if program is None:
        raise CliError(f"no program {command[0]!r} on PATH")
    env = environment(args.name)
    if not os.path.exists(env[ADAPTER_VARIABLE]):
        raise CliError(
            f"no host adapter for bus {args.name!r} on this machine "
            f"(start the bus with fw1394 bus up --name {args.name})"
        )
    # The program takes this process's place: its exit status and signals are the run's.
    os.execve(program, command, env)
    return 0  # not reached
