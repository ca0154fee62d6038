"""Which board a bus member emulates, when the process is on this host.

The member table carries a board ID but not the board kind. A node process
started here can tell it anyway: ``fw1394 bus up`` writes the kind of every
node it starts into the bus's ``nodes.json``, and a node started by hand
has ``--board KIND`` on its command line. Members on other hosts or in
other PID namespaces stay unknown.
"""

from __future__ import annotations

from collections.abc import Sequence

from fw1394.boards import BOARDS
from fw1394.boards.snake2010.regmap import REGISTER_MAP as SNAKE2010_MAP
from fw1394.transport.sansio.config import BusNameError
from fw1394.transport.sansio.wire import MemberInfo
from fw1394.transport.supervision.runtime import bus_dir, read_nodes

#: ``fw1394 node run`` serves plain memory unless told otherwise.
NODE_DEFAULT_BOARD = "memory"


def member_kind(bus: str, me: MemberInfo, member: MemberInfo) -> str | None:
    """Board kind of ``member`` as seen by host ``me`` on bus ``bus``; None if unknown."""
    local = member.address == me.address and member.pid_namespace == me.pid_namespace
    if not local or not member.pid:
        return None
    try:
        records = read_nodes(bus_dir(bus))
    except BusNameError:
        records = []
    for record in records:
        if record.pid == member.pid:
            return record.board
    try:
        with open(f"/proc/{member.pid}/cmdline", "rb") as file:
            argv = file.read().decode(errors="replace").split("\0")
    except OSError:
        return None
    return kind_from_argv(argv)


def kind_from_argv(argv: Sequence[str]) -> str | None:
    """The ``--board`` of a node's command line (``python -m fw1394.node`` or ``fw1394
    node run``); None if it is not one."""
    if "fw1394.node" not in argv and ("node" not in argv or "run" not in argv):
        return None
    for position, word in enumerate(argv):
        if word == "--board" and position + 1 < len(argv):
            return argv[position + 1]
        if word.startswith("--board="):
            return word.split("=", 1)[1]
    return NODE_DEFAULT_BOARD


def snake_channels(kind: str) -> int | None:
    """Channel count of a snake2010-family board kind; None for any other kind."""
    entry = BOARDS.get(kind)
    registers = entry.registers if entry else None
    if registers is None or registers.board != SNAKE2010_MAP.board:
        return None
    return len(registers.group("channel").copies)
