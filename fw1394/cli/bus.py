"""``fw1394 bus up|status|reset|down`` and ``fw1394 node run``: the virtual 1394 bus."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any

from fw1394.boards.qla1.busnode import add_eth1394_options, eth1394_node_arguments
from fw1394.boards.registry import board_defects, board_kind
from fw1394.cli.common import CliError, print_json_lines, print_table
from fw1394.cli.fuzz import add_defect_option, checked_defects, defect_arguments
from fw1394.engine.policy import POLICIES
from fw1394.transport.config import DEFAULT_BUS, BusConfig, BusNameError
from fw1394.transport.faults import FaultConfig
from fw1394.transport.membership import Timing
from fw1394.transport.wire import MAX_MEMBERS, MemberInfo

if TYPE_CHECKING:
    from fw1394.transport.bus_port import BusPort

DEFAULT_TIMING = Timing()


def default_policy(board: str) -> str:
    return board_kind(board).policy


BUS_EXAMPLES = """\
examples:
  fw1394 bus up --nodes 4                 four memory-backed nodes on bus "default"
  fw1394 bus up --name arm --nodes 2 --board snake2010
  fw1394 bus up --nodes 1 --board rtl:thesis   the thesis link RTL in simulation (docs/rtl.md)
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


# -- options shared by every bus member ---------------------------------------------------
def add_bus_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("bus")
    group.add_argument("--name", default=DEFAULT_BUS, help="bus name (default: %(default)s)")
    group.add_argument(
        "--interface",
        default="127.0.0.1",
        help="local IPv4 address multicast uses (default: loopback only)",
    )
    group.add_argument(
        "--ttl", type=int, default=0, help="multicast TTL: 0 stays on this host, 1 spans a LAN"
    )


def add_member_options(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group("membership and faults")
    group.add_argument("--heartbeat", type=float, default=DEFAULT_TIMING.heartbeat, help="seconds")
    group.add_argument(
        "--lease", type=float, default=DEFAULT_TIMING.lease, help="silence that ends membership (s)"
    )
    group.add_argument("--loss", type=float, default=0.0, help="drop this share of async frames")
    group.add_argument("--duplicate", type=float, default=0.0, help="send this share twice")
    group.add_argument("--delay", type=float, default=0.0, help="delay this share of frames")
    group.add_argument(
        "--delay-time", type=float, default=0.002, help="how long a delay is (s, default 0.002)"
    )
    group.add_argument("--fault-seed", type=int, default=None, help="seed of the fault dice")


def bus_config(args: argparse.Namespace) -> BusConfig:
    try:
        return BusConfig(args.name, interface=args.interface, ttl=args.ttl)
    except (BusNameError, ValueError) as error:
        raise CliError(str(error)) from None


def timing(args: argparse.Namespace) -> Timing:
    if not 0 < args.heartbeat < args.lease:
        raise CliError(f"--heartbeat {args.heartbeat} must be positive and below --lease")
    return Timing(heartbeat=args.heartbeat, lease=args.lease)


def faults(args: argparse.Namespace) -> FaultConfig:
    try:
        return FaultConfig(
            loss=args.loss,
            duplicate=args.duplicate,
            delay=args.delay,
            delay_seconds=args.delay_time,
            seed=args.fault_seed,
        )
    except ValueError as error:
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


def member_arguments(args: argparse.Namespace) -> list[str]:
    """The membership and fault options again, to hand on to node processes."""
    out = ["--heartbeat", str(args.heartbeat), "--lease", str(args.lease)]
    for name in ("loss", "duplicate", "delay"):
        if getattr(args, name):
            out += [f"--{name}", str(getattr(args, name))]
    out += ["--delay-time", str(args.delay_time)]
    if args.fault_seed is not None:
        out += ["--fault-seed", str(args.fault_seed)]
    return out


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
    table = [("PHY", "ROLE", "BOARD", "PID", "ADDRESS")]
    for row in rows:
        board = "-" if row["board_id"] is None else str(row["board_id"])
        table.append((str(row["phy_id"]), row["role"], board, str(row["pid"]), str(row["address"])))
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
    add_eth1394_options(up)  # JHU Eth1394 (fw1394.boards.qla1.busnode)
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
    run = node_actions.add_parser("run", help="run a node until interrupted")
    add_node_run_options(run)
    run.set_defaults(handler=node_run)


def add_node_run_options(run: argparse.ArgumentParser) -> None:
    add_bus_options(run)
    add_member_options(run)
    run.add_argument("--board", default="memory", help="board kind (default: memory)")
    add_eth1394_options(run)  # JHU Eth1394 (fw1394.boards.qla1.busnode)
    run.add_argument("--board-id", type=int, default=0, help="the board's own ID (rotary switch)")
    run.add_argument("--memory-size", type=int, default=65536, help="bytes of a memory node")
    run.add_argument(
        "--policy",
        choices=sorted(POLICIES),
        default=None,
        help="how the node answers (default: quick for memory, thesis/jhu for boards)",
    )
    run.add_argument("--rank", type=int, default=None, help="order key (default: start time)")
    run.add_argument("--parent-pid", type=int, default=None, help=argparse.SUPPRESS)
    run.add_argument("--quiet", action="store_true", help="no log lines on stderr")
    add_defect_option(run)  # planted bugs for the fuzzer (fw1394.engine.defects)


def _bus_handler(action: str) -> Any:
    handlers = {"up": bus_up, "status": bus_status, "reset": bus_reset, "down": bus_down}
    return handlers[action]


# -- handlers -----------------------------------------------------------------------------
def bus_up(args: argparse.Namespace) -> int:
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
    for kind in args.board.split(","):
        _check_board(kind)
        _checked_defects(kind, args.defect)  # before any process starts
    node_arguments = (*member_arguments(args),)
    # -- JHU Eth1394 (fw1394.boards.qla1.busnode): qla1 firmware and Ethernet cabling --
    try:
        node_arguments += eth1394_node_arguments(args)
    except ValueError as error:
        raise CliError(str(error)) from None
    # -- end JHU Eth1394 --
    node_arguments += defect_arguments(args)  # planted bugs for the fuzzer
    timing(args)
    faults(args)
    log = prepare(config.name) / "bus.log"
    bus = LaunchedBus(
        config, args.nodes, board=args.board, attached=False, node_arguments=node_arguments, log=log
    )
    try:
        bus.start(timeout=args.timeout)
        view = bus.wait_members(timeout=args.timeout)
    except AlreadyUpError as error:
        raise CliError(str(error)) from None  # the running bus is not ours to stop
    except LaunchError as error:
        bus.stop()
        raise CliError(f"{error} (log: {log})") from None
    except KeyboardInterrupt:
        bus.stop()
        raise
    print_members(member_rows(view.members), args.json)
    return 0


def _check_board(kind: str) -> None:
    if kind == "memory":
        return
    if kind.startswith("rtl:"):  # a link design in simulation (fw1394.rtl)
        from fw1394.rtl.busnode import check_spec

        try:
            check_spec(kind)
        except ValueError as error:
            raise CliError(str(error)) from None
        return
    from fw1394.boards import BOARDS

    if kind not in BOARDS:
        known = ", ".join(sorted(BOARDS))
        raise CliError(f"unknown board kind {kind!r}; known kinds: {known}")


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
    print_members(member_rows(view.members), args.json)
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
    from fw1394.node.process import BusRefusedError, NodeOptions, run_node
    from fw1394.transport.membership import BusReset
    from fw1394.transport.procs import die_with_parent

    if args.parent_pid is not None:
        die_with_parent(args.parent_pid)
    config = bus_config(args)
    # -- JHU Eth1394 (fw1394.boards.qla1.busnode): qla1 boards run with their Ethernet side --
    if args.board == "qla1":
        from fw1394.boards.qla1.busnode import run_from_arguments

        try:
            eth1394_node_arguments(args)
            run_from_arguments(args, config, timing(args), faults(args))
        except ValueError as error:
            raise CliError(str(error)) from None
        except OSError as error:
            raise CliError(f"cannot join bus {config.name!r} or open Eth1394: {error}") from None
        return 0
    # -- end JHU Eth1394 --
    # -- RTL link designs (fw1394.rtl): this process runs the simulation --
    if args.board.startswith("rtl:"):
        return _rtl_node_run(args, config)
    space = _make_space(args)
    options = NodeOptions(
        config=config,
        board_id=args.board_id,
        rank=args.rank,
        timing=timing(args),
        faults=faults(args),
        policy=POLICIES[args.policy or default_policy(args.board)],
        defects=checked_defects(args.board, args.defect),
    )

    def log(change: BusReset) -> None:
        print(
            f"fw1394 node: generation {change.generation}: physical ID {change.phy_id} "
            f"of {len(change.members)}",
            file=sys.stderr,
        )

    def warn(text: str) -> None:
        print(f"fw1394 node: warning: {text}", file=sys.stderr)

    try:
        run_node(space, options, on_reset=None if args.quiet else log, on_warning=warn)
    except BusRefusedError as error:
        raise CliError(f"bus {config.name!r} refused this node: {error}") from None
    except OSError as error:
        raise CliError(f"cannot join bus {config.name!r}: {error}") from None
    return 0


def _checked_defects(kind: str, names: list[str]) -> frozenset[str]:
    if not kind.startswith("rtl:"):
        return checked_defects(kind, names)
    from fw1394.fuzz.targets import rtl_defects

    unknown = sorted(set(names) - rtl_defects(kind.removeprefix("rtl:")).keys())
    if unknown:
        raise CliError(f"unknown defect {unknown[0]!r} for {kind}; see docs/rtl.md")
    return frozenset(names)


def _rtl_node_run(args: argparse.Namespace, config: Any) -> int:
    from fw1394.node.process import NodeOptions
    from fw1394.rtl.busnode import BusRefusedError, check_spec, run_rtl_node

    try:
        check_spec(args.board)
    except ValueError as error:
        raise CliError(str(error)) from None
    options = NodeOptions(
        config=config,
        board_id=args.board_id,
        rank=args.rank,
        timing=timing(args),
        faults=faults(args),
        defects=_checked_defects(args.board, args.defect),
    )
    try:
        run_rtl_node(
            args.board,
            options,
            on_warning=lambda text: print(f"fw1394 node: warning: {text}", file=sys.stderr),
        )
    except BusRefusedError as error:
        raise CliError(f"bus {config.name!r} refused this node: {error}") from None
    except OSError as error:
        raise CliError(f"cannot run the RTL node on bus {config.name!r}: {error}") from None
    return 0


def _make_space(args: argparse.Namespace) -> Any:
    if not 0 <= args.board_id <= 0xFE:
        raise CliError(f"--board-id {args.board_id} is outside 0..254")
    if args.board == "memory":
        from fw1394.boards.memory.board import MemorySpace

        if args.memory_size <= 0 or args.memory_size % 4:
            raise CliError(f"--memory-size {args.memory_size} is not a positive multiple of 4")
        return MemorySpace(args.memory_size, board_id=args.board_id)
    from fw1394.boards import make_board

    _check_board(args.board)
    try:
        defects = board_defects(args.board, checked_defects(args.board, args.defect))
        return make_board(args.board, board_id=args.board_id, defects=defects)
    except (ValueError, TypeError) as error:
        raise CliError(f"board {args.board!r}: {error}") from None


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
