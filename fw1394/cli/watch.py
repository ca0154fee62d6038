"""``fw1394 watch NODE...``: live terminal view of snake2010 boards on a virtual bus."""

from __future__ import annotations

import argparse
import shutil
import sys
import time
from typing import TYPE_CHECKING, Any

from fw1394.cli.attach import add_attach_options, host_member, open_port
from fw1394.cli.common import CliError, integer, print_json
from fw1394.node.description import add_bus_options, add_member_options

if TYPE_CHECKING:
    from fw1394.host.adapter_port import AdapterPort
    from fw1394.host.bus_port import BusPort
    from fw1394.watch.readings import BoardReading
    from fw1394.watch.sampler import WatchedBoard

DEFAULT_CHANNELS = 7
MAX_RATE_HZ = 50.0
EPILOG = """\
The view shows, per board, the status word decoded (board ID, watchdog
timeout, amplifier faults and enables, LEDs), the watchdog period and the
time since the previous latch; per channel the encoder count (from the
0x800000 mid-point) and edge period, pot, motor current, motor command and
current limit read back from the DAC, and the pot's mode and feedback gain.

keys: up/down (j/k) channel, left/right or tab board, 1-7 channel,
  e/d enable/disable the selected amplifier, E/D every amplifier shown,
  +/- change the selected motor command by --step codes, 0 stop it,
  r read the pot settings again, q quit.
On leaving, the motor commands it changed go back to 0x8000 (stop) and the
amplifiers it enabled are switched off. See docs/watch.md.

examples:
  fw1394 bus up --board snake2010,snake2010-ztheta --nodes 2
  fw1394 watch 0 1
  fw1394 watch 0 --once
  fw1394 watch 0 --once --json --name arm
"""


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "watch",
        help="live terminal view of snake2010 boards on a virtual bus",
        description="Watch and drive snake2010 boards on a virtual 1394 bus, as a host.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "nodes", nargs="+", type=integer, metavar="NODE", help="physical ID of a board (0-62)"
    )
    parser.add_argument(
        "--channels",
        type=integer,
        metavar="N",
        default=None,
        help=f"channels per board, 1-7 (default: from the board kind, else {DEFAULT_CHANNELS})",
    )
    parser.add_argument("--once", action="store_true", help="print one snapshot and exit")
    parser.add_argument("--json", action="store_true", help="with --once: one JSON object")
    parser.add_argument(
        "--rate",
        type=float,
        metavar="HZ",
        default=10.0,
        help=f"refreshes per second (default 10, 1-{MAX_RATE_HZ:g})",
    )
    parser.add_argument(
        "--step",
        type=integer,
        default=256,
        metavar="CODES",
        help="motor-command change per +/- key (DAC codes, default 256)",
    )
    parser.add_argument(
        "--read-only",
        action="store_true",
        help="never write to the boards: no pot handshake, commands refused",
    )
    parser.add_argument(
        "--timeout", type=float, default=0.5, metavar="S", help="ack and response timeout (s)"
    )
    add_attach_options(parser)
    add_bus_options(parser)
    add_member_options(parser)
    parser.set_defaults(handler=run)


def _check(args: argparse.Namespace) -> None:
    for node in args.nodes:
        if not 0 <= node <= 62:
            raise CliError(f"node {node} is not a board's physical ID (0-62)")
    if len(set(args.nodes)) != len(args.nodes):
        raise CliError("a node is listed twice")
    if args.channels is not None and not 1 <= args.channels <= 7:
        raise CliError(f"--channels {args.channels}: a snake2010 board has 1 to 7")
    if args.json and not args.once:
        raise CliError("--json goes with --once (the live view is for a terminal)")
    if not 1 <= args.rate <= MAX_RATE_HZ:
        raise CliError(f"--rate {args.rate:g}: use 1 to {MAX_RATE_HZ:g} refreshes per second")
    if not 1 <= args.step <= 0x8000:
        raise CliError(f"--step {args.step}: use 1 to 32768 DAC codes")
    if args.timeout <= 0:
        raise CliError(f"--timeout {args.timeout} must be positive")
    if not args.once and not (sys.stdin.isatty() and sys.stdout.isatty()):
        raise CliError("the live view needs a terminal; use --once for a snapshot")


def run(args: argparse.Namespace) -> int:
    _check(args)
    with open_port(args) as port:
        boards = _attach(port, args)
        if args.once:
            return _snapshot(boards, args)
        return _live(boards, args)


def _attach(port: AdapterPort | BusPort, args: argparse.Namespace) -> list[WatchedBoard]:
    """A watched board per NODE, checked to be a snake2010 board where that can be told."""
    from fw1394.watch.detect import member_kind, snake_channels
    from fw1394.watch.sampler import WatchedBoard

    name = args.name
    members = dict(port.nodes())
    if not members:
        raise CliError(
            f"bus {name!r} has no nodes (is it up? "
            f"fw1394 bus up --name {name} --board snake2010 --nodes N)"
        )
    boards = []
    for node in args.nodes:
        member = members.get(node)
        if member is None:
            known = ", ".join(str(phy) for phy in sorted(members))
            raise CliError(
                f"no node {node} on bus {name!r} (nodes: {known}; is it up? "
                f"fw1394 bus up --name {name} --board snake2010 --nodes N)"
            )
        if member.host:
            raise CliError(f"node {node} on bus {name!r} is a host, not a board")
        kind = member_kind(name, host_member(port), member)
        channels = None if kind is None else snake_channels(kind)
        if kind is not None and channels is None:
            raise CliError(f"node {node} is a {kind!r} board; fw1394 watch shows snake2010 boards")
        count = args.channels or channels or DEFAULT_CHANNELS
        boards.append(WatchedBoard(port, node, kind or "unknown kind", count))
    return boards


def _snapshot(boards: list[WatchedBoard], args: argparse.Namespace) -> int:
    from fw1394.watch.conversions import Conversions
    from fw1394.watch.view import BoardPanel, reading_dict, view_lines

    conversions = Conversions.of()
    readings = [_read_once(watched, args.read_only) for watched in boards]
    if args.json:
        objects = [reading_dict(reading, conversions) for reading in readings]
        print_json({"bus": args.name, "time": time.time(), "boards": objects})
        return 0
    title = f"fw1394 watch  bus {args.name}  {time.strftime('%Y-%m-%d %H:%M:%S')}"
    panels = [BoardPanel(r.node, r.kind, r) for r in readings]
    # A terminal gets what fits its width (wrapped, columns named when hidden);
    # a pipe gets every column.
    width = shutil.get_terminal_size().columns if sys.stdout.isatty() else None
    for line in view_lines(title, panels, conversions, width=width):
        print(line.text.rstrip())
    return 0


def _read_once(watched: WatchedBoard, read_only: bool) -> BoardReading:
    """One full reading; a second try if the first meets a bus reset or a lost packet."""
    from fw1394.watch.sampler import BOARD_ERRORS

    problem: Exception | None = None
    for _ in range(2):
        try:
            if not read_only:
                watched.read_pot_settings()
            return watched.sample()
        except BOARD_ERRORS as error:
            problem = error
    raise CliError(f"node {watched.node}: {problem}")


def _live(boards: list[WatchedBoard], args: argparse.Namespace) -> int:
    from fw1394.watch.controls import Controller
    from fw1394.watch.conversions import Conversions
    from fw1394.watch.live import live_render, run_live
    from fw1394.watch.sampler import BOARD_ERRORS

    if not args.read_only:
        for watched in boards:
            try:
                watched.read_pot_settings()
            except BOARD_ERRORS as error:
                watched.problem = f"pot settings not read: {error}"
    controller = Controller(boards, args.step, args.read_only)
    render = live_render(args.name, Conversions.of(), args.rate)
    return 0 if run_live(controller, render, args.rate) else 1
