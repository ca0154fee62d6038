"""``fw1394 demo``: the README's first command."""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from fw1394.cli.common import CliError, print_json

EPILOG = """\
What it does: starts a virtual 1394 bus with the two FPGA boards of the
thesis's Snake Robot (7 axes + 4 axes), runs a 1 kHz position loop on all 11
axes through the host API (one block read and one block write per board per
cycle), prints live progress and a summary, writes a plot of commanded versus
measured positions, and stops every process it started. The summary counts
the transactions the host sent by kind, and gives each process's CPU time,
wake-ups and preemptions per cycle (from /proc).

examples:
  fw1394 demo
  fw1394 demo --duration 10 --plot run.png
  fw1394 demo --json --no-plot
"""


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "demo",
        help="run the built-in snake-robot demo on a virtual bus",
        description="Servo the 11 axes of an emulated Snake Robot over a virtual 1394 bus.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--duration",
        "--seconds",
        dest="seconds",
        type=float,
        default=3.0,
        help="loop duration in seconds (default 3; --seconds is the older spelling)",
    )
    parser.add_argument("--rate", type=float, default=1000.0, help="loop rate in Hz (default 1000)")
    parser.add_argument(
        "--plot",
        type=Path,
        default=Path("fw1394-demo.png"),
        help="where to write the plot (default: fw1394-demo.png)",
    )
    parser.add_argument("--no-plot", action="store_true", help="do not write a plot")
    parser.add_argument(
        "--capture",
        type=Path,
        default=Path("fw1394-demo.pcapng"),
        help="where to record the bus traffic (default: fw1394-demo.pcapng); "
        "read it with fw1394 dissect or Wireshark",
    )
    parser.add_argument("--no-capture", action="store_true", help="do not record the traffic")
    parser.add_argument("--json", action="store_true", help="print the summary as JSON")
    parser.set_defaults(handler=run)


def _progress(result: Any, elapsed: float) -> None:
    """The demo's status line on a terminal, redrawn in place, problems in colour."""
    from rich.console import Console
    from rich.control import Control
    from rich.segment import ControlType
    from rich.text import Text

    worst = max((abs(e) for e in result.final_errors), default=0.0)
    line = Text.assemble(
        f"  t={elapsed:5.2f} s  cycles={result.cycles:6d}  ",
        (f"overruns={result.overruns:4d}", "bold red" if result.overruns else ""),
        f"  |error|max={worst:7.0f} counts  ",
        (
            f"watchdog trips={result.watchdog_trips}",
            "bold red" if result.watchdog_trips else "green",
        ),
    )
    console = Console(file=sys.stderr, highlight=False)
    console.control(Control.move_to_column(0), Control((ControlType.ERASE_IN_LINE, 2)))
    console.print(line, end="", overflow="crop", no_wrap=True)


def run(args: argparse.Namespace) -> int:
    if not 0 < args.seconds <= 3600:
        raise CliError(f"--duration {args.seconds}: use a duration between 0 and 3600 s")
    if not 10 <= args.rate <= 10000:
        raise CliError(f"--rate {args.rate}: use 10 to 10000 Hz")
    for wanted, path, option in (
        (not args.no_plot, args.plot, "--plot"),
        (not args.no_capture, args.capture, "--capture"),
    ):
        if not wanted:
            continue
        if path.is_dir():
            raise CliError(f"{option} {path}: is a directory; name a file in it")
        if not path.parent.is_dir():
            raise CliError(f"{option} {path}: directory {path.parent} does not exist")
        if not os.access(path.parent, os.W_OK):
            raise CliError(f"{option} {path}: directory {path.parent} is not writable")
    from fw1394.demo import run_demo
    from fw1394.demo.report import plot, summary, traffic

    live = sys.stderr.isatty() and not args.json
    if not args.json:
        print(
            f"fw1394 demo: 2 boards (7 + 4 axes) on a virtual 1394 bus, "
            f"{args.rate:.0f} Hz for {args.seconds:g} s",
            flush=True,
        )
    result = run_demo(
        args.seconds,
        args.rate,
        progress=_progress if live else None,
        capture=None if args.no_capture else args.capture,
    )
    if live:
        sys.stderr.write("\n")
    numbers = summary(result)
    if not args.no_plot:
        try:
            plot(result, args.plot)
        except ImportError:
            numbers["plot"] = "matplotlib is not installed (pip install matplotlib)"
        else:
            numbers["plot"] = str(args.plot)
    if not args.no_capture:
        numbers["capture"] = str(args.capture)
        numbers["traffic"] = traffic(args.capture)
    if args.json:
        print_json(numbers)
    else:
        _print_summary(numbers)
    return 0


def _print_summary(numbers: dict[str, Any]) -> None:
    period, bus = numbers["period_us"], numbers["cycle_bus_time_us"]
    rms = numbers["tracking_rms_counts"]
    print(
        f"cycles            {numbers['cycles']} in {numbers['seconds']} s "
        f"({numbers['rate_hz']} Hz achieved)"
    )
    print(
        f"loop period       p50 {period['p50']} us   p99 {period['p99']} us   "
        f"max {period['max']} us   overruns {numbers['overruns']} "
        f"({numbers['overrun_percent']} %)"
    )
    print(
        f"bus time/cycle    p50 {bus['p50']} us   p99 {bus['p99']} us   max {bus['max']} us "
        f"({numbers['transactions_per_cycle']} transactions)"
    )
    kinds = ", ".join(f"{n} {k}" for k, n in numbers["transactions_by_kind"].items())
    print(f"host sent         {kinds}")
    idle = numbers["idle"]
    crowding = "crowded: every member blocks" if idle["crowded"] else "members may poll"
    print(
        f"idle strategy     {idle['strategy']} on the {idle['medium']} medium, "
        f"{idle['members_here']} members on {idle['cpus']} CPUs ({crowding})"
    )
    for name, cost in numbers["per_cycle_by_process"].items():
        print(
            f"  {name:24} {cost['cpu_us']:7.1f} us CPU  {cost['wakeups']:5.2f} wake-ups  "
            f"{cost['preemptions']:5.2f} preemptions per cycle"
        )
    print(
        f"  {'all of them':24} {numbers['cpu_us_per_cycle']:7.1f} us CPU per cycle "
        f"({numbers['cpus_busy']:.2f} CPUs busy)"
    )
    print(
        f"watchdog trips    {numbers['watchdog_trips']}   "
        f"bus resets during the loop {numbers['bus_resets']}"
    )
    print("tracking RMS      " + " ".join(f"{e:.0f}" for e in rms) + " counts (axes 1-11)")
    if "plot" in numbers:
        print(f"plot              {numbers['plot']}")
    if "traffic" in numbers:
        _print_traffic(numbers["capture"], numbers["traffic"])


def _print_traffic(path: str, stats: dict[str, Any]) -> None:
    if "error" in stats:
        print(f"capture           {path} (could not dissect: {stats['error']})")
        return
    records = stats.get("records", {})
    print(
        f"capture           {path}: {stats.get('records_read', 0)} records "
        f"({records.get('async_packet', 0)} packets, {stats.get('bus_resets', 0)} bus resets "
        "with the members' joins), "
        f"fw1394 dissect {path} --transactions for every transaction"
    )
    kinds = ", ".join(f"{n} {k}" for k, n in stats.get("transactions", {}).items())
    print(f"transactions      {kinds}")
    for kind, latency in stats.get("latency_by_kind", {}).items():
        print(
            f"  {kind:26} n={latency['count']:6d} p50 {latency['p50_ns'] / 1000:7.1f} us   "
            f"p99 {latency['p99_ns'] / 1000:7.1f} us (as the tap saw them)"
        )
    errors = stats.get("errors", {}).get("total", 0)
    print(f"errors            {errors}")
