"""``fw1394 bus up|status|reset|down`` and ``fw1394 node run``: the virtual 1394 bus."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Any, TypeVar

from fw1394.cli.common import CliError, print_json_lines, print_table
from fw1394.cli.fuzz import defect_arguments
from fw1394.node import description
from fw1394.node.description import (
    NodeDescriptionError,
    add_bus_options,
    add_defect_option,
    add_ethernet_options,
    add_member_options,
    add_node_options,
    member_arguments,
)
from fw1394.transport.config import BusConfig
from fw1394.transport.faults import FaultConfig
from fw1394.transport.membership import Timing
from fw1394.transport.wire import MAX_MEMBERS, MemberInfo

if TYPE_CHECKING:
    from fw1394.transport.bus_port import BusPort

T = TypeVar("T")
__all__ = ["add_bus_options", "add_member_options", "bus_config", "host_port", "register"]


BUS_EXAMPLES = """\
examples:
  fw1394 bus up --nodes 4                 four memory-backed nodes on bus "default"
  fw1394 bus up --name arm --nodes 2 --board snake2010
  fw1394 bus status --name arm
  fw1394 bus reset                        ask the coordinator for a bus reset
  fw1394 bus down --name arm              stop every process of bus "arm"
"""
NODE_EXAMPLES = """\
examples:
  fw1394 node run                         a memory node on bus "default" (Ctrl-C leaves)
  fw1394 node run --board snake2010 --board-id 3 --loss 0.05
  fw1394 node run --interface 10.0.0.2 --ttl 1    a node of a bus that spans a LAN
"""


# -- options shared by every bus member (fw1394.node.description) --------------------------
def bus_config(args: argparse.Namespace) -> BusConfig:
    return _checked(description.bus_config, args)


def timing(args: argparse.Namespace) -> Timing:
    return _checked(description.timing, args)


def faults(args: argparse.Namespace) -> FaultConfig:
    return _checked(description.faults, args)


def _checked(make: Callable[[argparse.Namespace], T], args: argparse.Namespace) -> T:
    try:
        return make(args)
    except NodeDescriptionError as error:
        raise CliError(str(error)) from None


def host_port(args: argparse.Namespace) -> BusPort:
    """A host port on the bus the options name, waiting ``--timeout`` per transaction."""
    from fw1394.transport.bus_port import BusPort

    config = bus_config(args)
    try:
        return BusPort(
            config,
            ack_timeout=args.timeout,
            split_timeout=args.timeout,
            timing=timing(args),
            faults=faults(args),
        )
    except OSError as error:
        raise CliError(f"cannot join bus {config.name!r}: {error}") from None


def member_rows(members: Sequence[MemberInfo]) -> list[dict[str, Any]]:
    return [
        {
            "phy_id": phy,
            "role": "host" if m.host else "node",
            "board_id": None if m.board_id == 0xFF else m.board_id,
            "pid": m.pid,
            "address": m.address,
        }
        for phy, m in enumerate(members)
    ]


def print_members(rows: list[dict[str, Any]], as_json: bool) -> None:
    if as_json:
        print_json_lines(rows)
        return
    table = [("PHY", "ROLE", "KIND", "GEN", "BOARD", "PID", "ADDRESS")]
    for row in rows:
        board = "-" if row["board_id"] is None else str(row["board_id"])
        kind = row.get("kind") or ("-" if row["role"] != "node" else "unknown")
        generation = str(row.get("generation", "-"))
        cells = (row["role"], kind, generation, board, str(row["pid"]), str(row["address"]))
        table.append((str(row["phy_id"]), *cells))
    print_table(table, indent="")


# -- registration -------------------------------------------------------------------------
def register(subparsers: Any) -> None:
    bus = subparsers.add_parser(
        "bus",
        help="run a virtual 1394 bus of node processes",
        description="Start, inspect, reset and stop a virtual 1394 bus in the background.",
        epilog=BUS_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = bus.add_subparsers(dest="action", metavar="ACTION", required=True)
    up = actions.add_parser("up", help="start N node processes in the background")
    add_bus_options(up)
    add_member_options(up)
    up.add_argument("--nodes", type=int, required=True, help=f"1..{MAX_MEMBERS}")
    up.add_argument(
        "--board",
        default="memory",
        help="board kind, or kinds separated by commas given to the nodes in turn "
        "(default: memory)",
    )
    add_ethernet_options(up)
    add_defect_option(up)  # planted bugs for the fuzzer, on every node
    up.add_argument("--timeout", type=float, default=60.0, help="seconds to wait for the nodes")
    up.add_argument("--json", action="store_true", help="JSON lines instead of a table")
    up.set_defaults(handler=_bus_handler("up"))
    for action, text in (
        ("status", "show the members of a running bus"),
        ("reset", "ask for a bus reset"),
        ("down", "stop every process of a bus"),
    ):
        sub = actions.add_parser(action, help=text)
        add_bus_options(sub)
        if action == "status":
            sub.add_argument("--json", action="store_true", help="JSON lines instead of a table")
        sub.add_argument("--timeout", type=float, default=2.0, help="seconds to listen")
        sub.set_defaults(handler=_bus_handler(action))

    node = subparsers.add_parser(
        "node",
        help="run one bus node in the foreground",
        description="Run one node (an emulated board) on a virtual 1394 bus until Ctrl-C.",
        epilog=NODE_EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    node_actions = node.add_subparsers(dest="action", metavar="ACTION", required=True)
    run = node_actions.add_parser(
        "run",
        help="run a node until interrupted",
        description="The same node as `python -m fw1394.node` (the node a bus starts).",
    )
    add_node_options(run)
    run.set_defaults(handler=node_run)


def _bus_handler(action: str) -> Any:
    handlers = {"up": bus_up, "status": bus_status, "reset": bus_reset, "down": bus_down}
    return handlers[action]


# -- handlers -----------------------------------------------------------------------------
def bus_up(args: argparse.Namespace) -> int:
    from fw1394.transport.adapter import wait_adapter
    from fw1394.transport.launch import AlreadyUpError, LaunchedBus, LaunchError
    from fw1394.transport.runtime import prepare

    config = bus_config(args)
    if not 1 <= args.nodes <= MAX_MEMBERS:
        raise CliError(f"--nodes {args.nodes}: a 1394 bus holds 1..{MAX_MEMBERS} nodes")
    if args.nodes == MAX_MEMBERS:
        print(
            f"fw1394: note: {MAX_MEMBERS} nodes fill the bus; a host cannot join it",
            file=sys.stderr,
        )
    node_arguments = (*member_arguments(args),)
    ethernet: set[tuple[str, ...]] = set()
    try:
        for kind in args.board.split(","):  # every node's options, before any process starts
            description.check_board(kind)
            description.checked_defects(kind, args.defect)
            ethernet.add(description.ethernet_arguments(kind, args))
    except NodeDescriptionError as error:
        raise CliError(str(error)) from None
    node_arguments += max(ethernet, key=len)  # kinds without an Ethernet side ignore them
    node_arguments += defect_arguments(args)  # planted bugs for the fuzzer
    if args.nodes < MAX_MEMBERS:  # the bus's shared host node (fw1394.transport.adapter)
        node_arguments += ("--adapter",)
    timing(args)
    faults(args)
    log = prepare(config.name) / "bus.log"
    bus = LaunchedBus(
        config, args.nodes, board=args.board, attached=False, node_arguments=node_arguments, log=log
    )
    try:
        bus.start(timeout=args.timeout)
        view = bus.wait_members(timeout=args.timeout)
        if args.nodes < MAX_MEMBERS:
            view = wait_adapter(config, bus.directory, args.timeout) or view
    except AlreadyUpError as error:
        raise CliError(str(error)) from None  # the running bus is not ours to stop
    except LaunchError as error:
        bus.stop()
        raise CliError(f"{error} (log: {log})") from None
    except KeyboardInterrupt:
        bus.stop()
        raise
    print_members(labelled_rows(config, view), args.json)
    return 0


def labelled_rows(config: BusConfig, view: Any) -> list[dict[str, Any]]:
    """The member rows with each member's board kind, generation and role (fw1394 lsnodes)."""
    from fw1394.cli.lsnodes import member_labels

    rows = member_rows(view.members)
    for row, label in zip(rows, member_labels(config, view.generation, view.members), strict=True):
        row.update(label)
    return rows


def bus_status(args: argparse.Namespace) -> int:
    from fw1394.transport.observe import watch
    from fw1394.transport.runtime import bus_dir, read_nodes, supervisor_alive

    config = bus_config(args)
    view = watch(config, args.timeout)
    directory = bus_dir(config.name)
    started = read_nodes(directory) if supervisor_alive(directory) else []
    if view is None:
        where = f"{len(started)} node processes started here, " if started else ""
        raise CliError(f"bus {config.name!r}: {where}no coordinator heard in {args.timeout} s")
    if not args.json:
        print(f"bus {config.name!r}: generation {view.generation}, {len(view.members)} members")
    print_members(labelled_rows(config, view), args.json)
    live = {m.pid for m in view.members}
    missing = [n for n in started if n.pid not in live]
    for node in missing:
        print(f"fw1394: warning: node process {node.pid} is not on the bus", file=sys.stderr)
    return 0


def bus_reset(args: argparse.Namespace) -> int:
    from fw1394.transport.observe import request_reset, watch

    config = bus_config(args)
    before = watch(config, args.timeout)
    if before is None:
        raise CliError(f"bus {config.name!r}: no coordinator heard in {args.timeout} s")
    request_reset(config)
    after = watch(config, args.timeout, lambda view: view.generation > before.generation)
    if after is None:
        raise CliError(f"bus {config.name!r}: no reset seen within {args.timeout} s")
    print(f"bus {config.name!r}: generation {before.generation} -> {after.generation}")
    return 0


def bus_down(args: argparse.Namespace) -> int:
    from fw1394.transport.runtime import bus_dir, read_nodes, stop_bus, supervisor_alive

    config = bus_config(args)
    directory = bus_dir(config.name)
    if supervisor_alive(directory) is None and not read_nodes(directory):
        raise CliError(f"no bus {config.name!r} is up here")
    killed = stop_bus(directory)
    if killed:
        print(f"fw1394: warning: had to kill {len(killed)} processes", file=sys.stderr)
    print(f"bus {config.name!r} is down")
    return 0


def node_run(args: argparse.Namespace) -> int:
    from fw1394.node.run import NodeStartError, run

    node = _checked(description.description_from_arguments, args)
    try:
        run(node)
    except NodeStartError as error:
        raise CliError(str(error)) from None
    return 0


def standalone(argv: Sequence[str]) -> int:
    """Entry point of spawned node processes: only these commands, a quick start."""
    from fw1394.cli.common import fail

    parser = argparse.ArgumentParser(prog="fw1394")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    try:
        status: int = args.handler(args)
    except CliError as error:
        return fail(str(error))
    return status


if __name__ == "__main__":
    sys.exit(standalone(sys.argv[1:]))
