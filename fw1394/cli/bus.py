"""``fw1394 bus up|status|reset|down`` and ``fw1394 node run``: the virtual 1394 bus."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import Any

from fw1394.cli.common import CliError, print_json, print_table
from fw1394.errors import Error
from fw1394.node import description
from fw1394.node.description import (
    add_bus_options,
    add_defect_option,
    add_ethernet_options,
    add_member_options,
    add_node_options,
    bus_config,
    faults,
    member_arguments,
    timing,
)
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.wire import MAX_MEMBERS, MemberInfo
from fw1394.transport.supervision.procs import pid_namespace

__all__ = ["register", "standalone"]


BUS_EXAMPLES = """\
examples:
  fw1394 bus up --nodes 4                 four memory-backed nodes on bus "default"
  fw1394 bus up --name arm --nodes 2 --board snake2010
  fw1394 bus up --nodes 1 --board rtl:thesis   the thesis link RTL in simulation (docs/rtl.md)
  fw1394 bus status --name arm
  fw1394 bus reset                        ask the coordinator for a bus reset
  fw1394 bus key --name arm               the bus key, for members on other hosts:
      FW1394_BUS_KEY=$(fw1394 bus key --name arm) fw1394 node run --name arm ...
  fw1394 bus down --name arm              stop every process of bus "arm"

A bus is keyed unless started with --insecure: only processes with its key
(this user's runtime directory, FW1394_BUS_KEY or FW1394_BUS_KEY_FILE) can
speak on it; frames without a valid MAC are dropped and counted (bus status).
Nodes that die are restarted with back-off unless --no-restart.
"""
NODE_EXAMPLES = """\
examples:
  fw1394 node run                         a memory node on bus "default" (Ctrl-C leaves)
  fw1394 node run --board snake2010 --board-id 3 --loss 0.05
  fw1394 node run --interface 10.0.0.2 --ttl 1    a node of a bus that spans a LAN
"""


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
        print_json(*rows)
        return
    counted = any("dropped" in row for row in rows)
    heading: tuple[str, ...] = ("PHY", "ROLE", "KIND", "GEN", "BOARD", "PID", "ADDRESS")
    table = [heading + (("DROPPED",) if counted else ())]
    for row in rows:
        board = "-" if row["board_id"] is None else str(row["board_id"])
        kind = row.get("kind") or ("-" if row["role"] != "node" else "unknown")
        generation = str(row.get("generation", "-"))
        cells = (row["role"], kind, generation, board, str(row["pid"]), str(row["address"]))
        line: tuple[str, ...] = (str(row["phy_id"]), *cells)
        if counted:
            kinds = ("dropped", "replayed", "malformed") if row.get("dropped") is not None else ()
            counts = [row.get(k) for k in kinds or ("malformed",)]
            line += ("-" if None in counts else str(sum(c or 0 for c in counts)),)
        table.append(line)
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
    up.add_argument(
        "--insecure",
        action="store_true",
        help="no bus key: any local process can send frames (for comparisons)",
    )
    up.add_argument(
        "--no-restart",
        action="store_true",
        help="leave a node process that dies down (default: restart it, with back-off)",
    )
    up.add_argument("--json", action="store_true", help="JSON lines instead of a table")
    up.set_defaults(handler=_bus_handler("up"))
    for action, text in (
        ("status", "show the members of a running bus and the frames they dropped"),
        ("reset", "ask for a bus reset"),
        ("down", "stop every process of a bus, nodes joined by hand included"),
        ("key", "print the bus key (hex) for members on other hosts"),
    ):
        sub = actions.add_parser(action, help=text)
        add_bus_options(sub)
        if action in ("status", "key"):
            sub.add_argument("--json", action="store_true", help="JSON instead of text")
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
    handlers = {
        "up": bus_up,
        "status": bus_status,
        "reset": bus_reset,
        "down": bus_down,
        "key": bus_key,
    }
    return handlers[action]


# -- handlers -----------------------------------------------------------------------------
def bus_up(args: argparse.Namespace) -> int:
    from fw1394.transport.host_adapter.server import wait_adapter
    from fw1394.transport.supervision.launch import AlreadyUpError, LaunchedBus, LaunchError
    from fw1394.transport.supervision.runtime import prepare

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
    for kind in args.board.split(","):  # every node's options, before any process starts
        description.check_board(kind)
        description.checked_defects(kind, args.defect)
        ethernet.add(description.ethernet_arguments(kind, args))
    node_arguments += max(ethernet, key=len)  # kinds without an Ethernet side ignore them
    # planted bugs for the fuzzer, handed on to each node process
    node_arguments += tuple(part for name in args.defect for part in ("--defect", name))
    if args.nodes < MAX_MEMBERS:  # the bus's shared host node (transport.host_adapter)
        node_arguments += ("--adapter",)
    timing(args)
    faults(args)
    from fw1394.transport.supervision.bus_key import new_key

    log = prepare(config.name) / "bus.log"
    bus = LaunchedBus(
        config,
        args.nodes,
        board=args.board,
        attached=False,
        node_arguments=node_arguments,
        log=log,
        key=None if args.insecure else new_key(),
        restart=not args.no_restart,
    )
    try:
        bus.start(timeout=args.timeout)
        view = bus.wait_members(timeout=args.timeout)
        if args.nodes < MAX_MEMBERS:
            view = wait_adapter(config, bus.directory, args.timeout) or view
    except AlreadyUpError:
        raise  # the running bus is not ours to stop
    except LaunchError as error:
        bus.stop()
        raise LaunchError(f"{error} (log: {log})") from None
    except KeyboardInterrupt:
        bus.stop()
        raise
    print_members(labelled_rows(config, view), args.json)
    return 0


def bus_key_of(config: BusConfig) -> bytes | None:
    """The key members of ``config``'s bus use here."""
    from fw1394.transport.supervision.bus_key import key_for

    return key_for(config)


def labelled_rows(config: BusConfig, view: Any) -> list[dict[str, Any]]:
    """The member rows with each member's board kind, generation and role (fw1394 lsnodes)."""
    from fw1394.cli.lsnodes import member_labels

    rows = member_rows(view.members)
    for row, label in zip(rows, member_labels(config, view.generation, view.members), strict=True):
        row.update(label)
    return rows


def bus_status(args: argparse.Namespace) -> int:
    from fw1394.transport.supervision.observe import watch
    from fw1394.transport.supervision.runtime import (
        bus_dir,
        read_members,
        read_nodes,
        supervisor_alive,
    )

    config = bus_config(args)
    keyed = bus_key_of(config) is not None
    view = watch(config, args.timeout)
    directory = bus_dir(config.name)
    started = read_nodes(directory) if supervisor_alive(directory) else []
    if view is None:
        where = f"{len(started)} node processes started here, " if started else ""
        raise CliError(f"bus {config.name!r}: {where}no coordinator heard in {args.timeout} s")
    if view.sealed:
        return _status_without_key(config.name, view.generation, args.json)
    members = {m.pid: m for m in read_members(directory)}
    rows = labelled_rows(config, view)
    for row in rows:
        record = members.get(row["pid"])
        row["dropped"] = None if record is None or record.forged is None else record.forged
        row["replayed"] = None if record is None or record.replayed is None else record.replayed
        row["malformed"] = None if record is None else record.malformed
    security = "keyed" if keyed else "insecure"
    if args.json:
        # One line per member, as ever; the bus's security rides on every line.
        print_json(*({**row, "security": security} for row in rows))
    else:
        dropped = sum(row["dropped"] or 0 for row in rows)
        replayed = sum(row["replayed"] or 0 for row in rows)
        malformed = sum(row["malformed"] or 0 for row in rows)
        counts = (
            f", {dropped} forged, {replayed} replayed and {malformed} malformed frames dropped"
            if keyed
            else f", {malformed} malformed frames dropped"
        )
        note = "" if keyed else " (INSECURE: any local process can send frames)"
        print(
            f"bus {config.name!r}: generation {view.generation}, {len(view.members)} members, "
            f"{security}{note}{counts}"
        )
        print_members(rows, False)
    live = {m.pid for m in view.members}
    missing = [n for n in started if n.pid not in live]
    for node in missing:
        print(f"fw1394: warning: node process {node.pid} is not on the bus", file=sys.stderr)
    return 0


NO_KEY_HERE = "keyed (no key here)"


def _status_without_key(name: str, generation: int, as_json: bool) -> int:
    # Members only from beacons whose MAC verified: without the key, none did.
    if as_json:
        print_json({"generation": generation, "security": NO_KEY_HERE, "members": None})
    else:
        print(
            f"bus {name!r}: generation {generation}, {NO_KEY_HERE}: members not shown, "
            "no beacon can be verified without the bus key "
            "(FW1394_BUS_KEY or FW1394_BUS_KEY_FILE)"
        )
    return 0


def bus_reset(args: argparse.Namespace) -> int:
    from fw1394.transport.supervision.observe import request_reset, watch

    config = bus_config(args)
    bus_key_of(config)
    before = watch(config, args.timeout)
    if before is None:
        raise CliError(f"bus {config.name!r}: no coordinator heard in {args.timeout} s")
    if before.sealed:
        raise CliError(
            f"bus {config.name!r} is {NO_KEY_HERE}: its members drop a reset request "
            "without it (FW1394_BUS_KEY or FW1394_BUS_KEY_FILE)"
        )
    request_reset(config, before.generation)
    after = watch(config, args.timeout, lambda view: view.generation > before.generation)
    if after is None:
        raise CliError(f"bus {config.name!r}: no reset seen within {args.timeout} s")
    print(f"bus {config.name!r}: generation {before.generation} -> {after.generation}")
    return 0


def bus_down(args: argparse.Namespace) -> int:
    from fw1394.transport.supervision.observe import watch
    from fw1394.transport.supervision.runtime import (
        bus_dir,
        read_members,
        read_nodes,
        stop_bus,
        stop_members,
        supervisor_alive,
    )

    config = bus_config(args)
    bus_key_of(config)
    directory = bus_dir(config.name)
    # Nodes joined by hand are members too: the runtime directory lists those of this
    # host, the coordinator's beacon every member (a wedged bus may send none).
    recorded = [m.pid for m in read_members(directory) if not m.host]
    view = watch(config, min(args.timeout, 0.5))
    beaconed = [] if view is None else [m for m in view.members if not m.host]
    supervised = supervisor_alive(directory) is not None or read_nodes(directory)
    if not supervised and not recorded and not beaconed:
        raise CliError(f"no bus {config.name!r} is up here")
    killed = stop_bus(directory)
    this_host = (config.interface, pid_namespace())
    local = [m.pid for m in beaconed if (m.address, m.pid_namespace) == this_host]
    elsewhere = [m for m in beaconed if m.pid not in local]
    stopped, killed_too, left = stop_members(sorted(set(recorded) | set(local)))
    killed += killed_too
    if killed:
        print(f"fw1394: warning: had to kill {len(killed)} processes", file=sys.stderr)
    for pid in left:
        print(f"fw1394: warning: could not stop node process {pid}", file=sys.stderr)
    for member in elsewhere:
        print(
            f"fw1394: warning: node process {member.pid} at {member.address} is not on this "
            "host (or in another PID namespace): stop it there",
            file=sys.stderr,
        )
    if left or elsewhere:
        print(f"bus {config.name!r} is down here; {len(left) + len(elsewhere)} nodes still run")
        return 1
    extra = f" ({len(stopped)} nodes joined by hand stopped)" if stopped else ""
    print(f"bus {config.name!r} is down{extra}")
    return 0


def bus_key(args: argparse.Namespace) -> int:
    config = bus_config(args)
    key = bus_key_of(config)
    if key is None:
        raise CliError(f"bus {config.name!r} has no key here (not up, or up with --insecure)")
    if args.json:
        print_json({"bus": config.name, "key": key.hex()})
    else:
        print(key.hex())
    return 0


def node_run(args: argparse.Namespace) -> int:
    from fw1394.node.run import run

    run(description.description_from_arguments(args))
    return 0


def standalone(argv: Sequence[str]) -> int:
    """Entry point of spawned node processes: only these commands, a quick start."""
    from fw1394.cli.common import fail

    parser = argparse.ArgumentParser(prog="fw1394")
    register(parser.add_subparsers(dest="command", required=True))
    args = parser.parse_args(argv)
    try:
        status: int = args.handler(args)
    except Error as error:
        return fail(" ".join(str(error).split()) or type(error).__name__)
    return status


if __name__ == "__main__":
    sys.exit(standalone(sys.argv[1:]))
