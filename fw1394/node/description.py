"""What a node process is: its bus, its board, its policy, defects, timing and faults.

A node is described once, as :class:`NodeDescription`. On a command line it
is the options :func:`add_node_options` defines (``python -m fw1394.node``
and ``fw1394 node run`` take the same ones, so a supervisor hands them on
as they are); :func:`description_from_arguments` checks them and turns them
into the description.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass, field, replace
from typing import Any

from fw1394.boards.registry import BOARDS, check_defects
from fw1394.engine.faults import FaultConfig
from fw1394.engine.policy import POLICIES
from fw1394.errors import UsageError
from fw1394.transport.sansio.config import DEFAULT_BUS, BusConfig, BusNameError
from fw1394.transport.sansio.membership import Timing

DEFAULT_TIMING = Timing()
#: The board a node serves unless told otherwise.
DEFAULT_BOARD = "memory"
#: The firmware a board with an Ethernet side runs unless told otherwise (bridge mode).
DEFAULT_FIRMWARE = 8


#: Boards named ``rtl:PORTMAP`` are link designs in simulation (fw1394.rtl, docs/rtl.md).
RTL_PREFIX = "rtl:"


class NodeDescriptionError(UsageError):
    """A node description no node could start with (one line for the user)."""


@dataclass(frozen=True)
class NodeDescription:
    """One node process of a virtual bus."""

    bus: BusConfig = field(default_factory=BusConfig)
    #: A kind of :data:`fw1394.boards.registry.BOARDS`.
    board: str = DEFAULT_BOARD
    #: The board's own ID (its rotary switch), 0..254.
    board_id: int = 0
    #: Order key among the nodes (physical IDs follow it); None: the start time.
    rank: int | None = None
    #: A key of :data:`fw1394.engine.policy.POLICIES`; None: the board kind's default.
    policy: str | None = None
    #: Planted bugs for the fuzzer (packet-level and the board's own).
    defects: frozenset[str] = frozenset()
    timing: Timing | None = None
    faults: FaultConfig | None = None
    #: No log lines on stderr.
    quiet: bool = False
    #: The node ends when this process does (a supervisor's pid).
    parent_pid: int | None = None
    #: Bytes of a memory node.
    memory_size: int = 65536
    #: Boards with an Ethernet side: where the host reaches it (ADDRESS[:PORT]); None: no cable.
    eth1394: str | None = None
    #: Boards with an Ethernet side: the firmware revision.
    firmware: int = DEFAULT_FIRMWARE

    @property
    def policy_name(self) -> str:
        return self.policy or BOARDS[self.board].policy


# -- the command line ---------------------------------------------------------------------
def add_bus_options(parser: argparse.ArgumentParser) -> None:
    """Which bus: ``--name``, ``--interface``, ``--ttl``."""
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
    """Membership timing and injected faults of a bus member."""
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


def add_ethernet_options(parser: argparse.ArgumentParser) -> None:
    """``--eth1394 [ADDRESS[:PORT]]`` and ``--firmware``: boards with an Ethernet side."""
    ethernet = ", ".join(sorted(name for name, kind in BOARDS.items() if kind.ethernet))
    group = parser.add_argument_group(f"JHU Eth1394 ({ethernet} boards)")
    group.add_argument(
        "--eth1394",
        nargs="?",
        const="127.0.0.1",
        default=None,
        metavar="ADDRESS[:PORT]",
        help="cable the board to a host at this loopback server IP (default 127.0.0.1:1394)",
    )
    group.add_argument(
        "--firmware",
        type=int,
        default=DEFAULT_FIRMWARE,
        help=f"firmware revision (default {DEFAULT_FIRMWARE}: bridge mode; "
        ">= 9 needs a network namespace)",
    )


def add_defect_option(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--defect",
        action="append",
        default=[],
        metavar="NAME",
        help="plant a bug for the fuzzer to find (list: fw1394 fuzz defects)",
    )


def add_node_options(parser: argparse.ArgumentParser) -> None:
    """Every option of a node description."""
    add_bus_options(parser)
    add_member_options(parser)
    kinds = ", ".join(sorted(BOARDS))
    parser.add_argument(
        "--board", default=DEFAULT_BOARD, help=f"board kind: {kinds} (default: %(default)s)"
    )
    add_ethernet_options(parser)
    parser.add_argument(
        "--board-id", type=int, default=0, help="the board's own ID (rotary switch)"
    )
    parser.add_argument("--memory-size", type=int, default=65536, help="bytes of a memory node")
    parser.add_argument(
        "--policy",
        choices=sorted(POLICIES),
        default=None,
        help="how the node answers (default: the board kind's: quick for memory, "
        "thesis/jhu for boards)",
    )
    parser.add_argument("--rank", type=int, default=None, help="order key (default: start time)")
    parser.add_argument(
        "--new-bus",
        action="store_true",
        help="nobody is on the bus yet: start it at once instead of listening a lease for "
        "its coordinator (bus up gives this to the first node of a bus it starts)",
    )
    parser.add_argument("--parent-pid", type=int, default=None, help=argparse.SUPPRESS)
    parser.add_argument("--quiet", action="store_true", help="no log lines on stderr")
    add_defect_option(parser)


def bus_config(args: argparse.Namespace) -> BusConfig:
    try:
        return BusConfig(args.name, interface=args.interface, ttl=args.ttl)
    except (BusNameError, ValueError) as error:
        raise NodeDescriptionError(str(error)) from None


def timing(args: argparse.Namespace) -> Timing:
    if not 0 < args.heartbeat < args.lease:
        raise NodeDescriptionError(
            f"--heartbeat {args.heartbeat} must be positive and below --lease"
        )
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
        raise NodeDescriptionError(str(error)) from None


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


def check_board(kind: str) -> None:
    if kind.startswith(RTL_PREFIX):
        _rtl_portmap(kind)
        return
    if kind not in BOARDS:
        known = ", ".join(sorted(BOARDS))
        raise NodeDescriptionError(f"unknown board kind {kind!r}; known kinds: {known}")


def checked_defects(kind: str, names: list[str]) -> frozenset[str]:
    if kind.startswith(RTL_PREFIX):
        from fw1394.rtl.defects import known_rtl_defects

        unknown = sorted(set(names) - known_rtl_defects(_rtl_portmap(kind)).keys())
        if unknown:
            raise NodeDescriptionError(f"unknown defect {unknown[0]!r} for {kind}; see docs/rtl.md")
        return frozenset(names)
    try:
        return check_defects(kind, names)
    except ValueError as error:
        raise NodeDescriptionError(str(error)) from None


def check_ethernet(kind: str, eth1394: str | None, firmware: int) -> None:
    """The Ethernet options make sense for board ``kind`` (before any process starts)."""
    if kind.startswith(RTL_PREFIX):
        if eth1394 is not None:
            raise NodeDescriptionError(
                "--eth1394: a link design in simulation has no Ethernet side"
            )
        return
    entry = BOARDS[kind]
    if entry.node_program is None:
        if eth1394 is not None:
            with_ethernet = " or ".join(sorted(n for n, k in BOARDS.items() if k.ethernet))
            raise NodeDescriptionError(f"--eth1394 needs --board {with_ethernet}, not {kind}")
        return
    try:
        entry.node_program.check(eth1394=eth1394, firmware=firmware)
    except ValueError as error:
        raise NodeDescriptionError(str(error)) from None


def ethernet_arguments(kind: str, args: argparse.Namespace) -> tuple[str, ...]:
    """The Ethernet options again for nodes of ``kind`` (none for a kind without them)."""
    check_ethernet(kind, args.eth1394, args.firmware)
    if kind.startswith(RTL_PREFIX) or BOARDS[kind].node_program is None:
        return ()
    out: tuple[str, ...] = ("--firmware", str(args.firmware))
    return out if args.eth1394 is None else (*out, "--eth1394", args.eth1394)


def description_from_arguments(args: argparse.Namespace) -> NodeDescription:
    """The node the options of :func:`add_node_options` describe, checked."""
    check_board(args.board)
    if not 0 <= args.board_id <= 0xFE:
        raise NodeDescriptionError(f"--board-id {args.board_id} is outside 0..254")
    if args.memory_size <= 0 or args.memory_size % 4:
        raise NodeDescriptionError(
            f"--memory-size {args.memory_size} is not a positive multiple of 4"
        )
    check_ethernet(args.board, args.eth1394, args.firmware)
    return NodeDescription(
        bus=bus_config(args),
        board=args.board,
        board_id=args.board_id,
        rank=args.rank,
        policy=args.policy,
        defects=checked_defects(args.board, args.defect),
        timing=replace(timing(args), found_after=0.0) if args.new_bus else timing(args),
        faults=faults(args),
        quiet=args.quiet,
        parent_pid=args.parent_pid,
        memory_size=args.memory_size,
        eth1394=args.eth1394,
        firmware=args.firmware,
    )


def _rtl_portmap(kind: str) -> Any:
    from fw1394.rtl.portmap import PortMapError, load, split_spec

    try:
        return load(split_spec(kind.removeprefix(RTL_PREFIX))[0])
    except PortMapError as error:
        raise NodeDescriptionError(str(error)) from None
