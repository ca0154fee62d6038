"""``fw1394 dissect``: read a 1394 trace and show its packets, transactions or statistics."""

from __future__ import annotations

import argparse
import os
import sys

from fw1394.cli.common import CliError, integer

EPILOG = """\
formats (detected, or named with --format):
  fw1394   fw1394's own pcap/pcapng (fw1394 capture)
  udp      pcap/pcapng of UDP port 1394 (JHU Eth1394), from tcpdump or Wireshark
  nosy     nosy-dump --output files
  kernel   Linux kernel text: firewire tracepoints, firewire-ohci debug lines

examples:
  fw1394 dissect trace.pcapng
  fw1394 dissect trace.pcapng -t --node 2 --tcode read_block_request
  fw1394 dissect dmesg.txt --stats --json
  fw1394 dissect trace.pcapng --plot-latency latency.png --plot-size size.png
"""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "dissect",
        help="show the packets, transactions or statistics of a trace",
        description="Read a 1394 trace and show its packets, transactions, statistics or ROMs.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", help="trace file")
    parser.add_argument(
        "--format",
        choices=("auto", "fw1394", "udp", "nosy", "kernel"),
        default="auto",
        help="input format (default: detect)",
    )
    views = parser.add_mutually_exclusive_group()
    views.add_argument(
        "--view",
        choices=("packets", "transactions", "stats", "rom"),
        default="packets",
        help="what to show (default: packets)",
    )
    views.add_argument(
        "-t",
        "--transactions",
        dest="view",
        action="store_const",
        const="transactions",
        help="requests, acks and responses joined, with latencies",
    )
    views.add_argument(
        "-s",
        "--stats",
        dest="view",
        action="store_const",
        const="stats",
        help="counts, latency percentiles, errors",
    )
    views.add_argument(
        "--rom", dest="view", action="store_const", const="rom", help="decoded configuration ROMs"
    )
    parser.add_argument("-v", "--verbose", action="store_true", help="every field of every packet")
    output = parser.add_mutually_exclusive_group()
    output.add_argument("--json", action="store_true", help="one JSON object per line")
    output.add_argument("--csv", action="store_true", help="comma-separated values with a header")
    parser.add_argument(
        "--node", action="append", type=integer, default=[], help="only this node (number or ID)"
    )
    parser.add_argument(
        "--tcode", action="append", default=[], help="only this tcode (number or name)"
    )
    parser.add_argument("--since", type=float, help="seconds after the first record")
    parser.add_argument("--until", type=float, help="seconds after the first record")
    parser.add_argument("--plot-latency", metavar="PNG", help="histogram of transaction times")
    parser.add_argument("--plot-size", metavar="PNG", help="transaction time against block size")
    parser.add_argument(
        "--verify-crc",
        action="store_true",
        help="recompute every CRC, even where an fw1394 trace recorded them as checked",
    )
    parser.add_argument(
        "--port", type=int, default=1394, help="UDP port of Eth1394 traffic (default 1394)"
    )
    parser.add_argument(
        "--threads", type=int, default=2, help="decoding threads (default 2; 1: none)"
    )
    parser.set_defaults(handler=run)


def tcode_values(texts: list[str]) -> frozenset[int]:
    from fw1394.packets import TCode

    values = set()
    for text in texts:
        for item in text.replace(",", " ").split():
            try:
                value = int(item, 0)
            except ValueError:
                try:
                    value = int(TCode[item])
                except KeyError:
                    names = ", ".join(t.name for t in TCode)
                    raise CliError(
                        f"unknown tcode {item!r} (use a number or one of: {names})"
                    ) from None
            if not 0 <= value <= 15:
                raise CliError(f"tcode {value} is not 0..15")
            values.add(value)
    return frozenset(values)


def run(args: argparse.Namespace) -> int:
    try:
        from fw1394.capture.formats import sources
        from fw1394.capture.views.dissection import Dissection, Options
        from fw1394.capture.views.trace_plots import (
            PlotError,
            plot_latency,
            plot_size,
            require_matplotlib,
        )
    except ImportError as error:
        # numpy carries the bulk path; without it there is nothing to dissect with.
        raise CliError(f"fw1394 dissect needs {error.name}: pip install {error.name}") from None

    if not os.path.isfile(args.file):
        raise CliError(f"{args.file}: no such file")
    plots = args.plot_latency or args.plot_size
    if plots:
        try:
            require_matplotlib()
        except PlotError as error:
            raise CliError(str(error)) from None
    if args.threads < 1:
        raise CliError("--threads must be at least 1")
    options = Options(
        view=args.view,
        output="json" if args.json else "csv" if args.csv else "text",
        verbose=args.verbose,
        nodes=frozenset(args.node),
        tcodes=tcode_values(args.tcode),
        since_s=args.since,
        until_s=args.until,
        verify_crc=True if args.verify_crc else None,
        workers=args.threads,
        want_plots=bool(plots),
    )
    try:
        fmt = sources.detect(args.file) if args.format == "auto" else args.format
        jobs = sources.jobs(args.file, fmt, (args.port,))
        outcome = Dissection(options, sys.stdout).run(jobs)
    except sources.SourceError as error:
        raise CliError(str(error)) from None
    except MemoryError:
        raise CliError("out of memory") from None
    except BrokenPipeError:
        raise  # output closed early (| head): main() ends quietly
    except (OSError, ValueError, RuntimeError, IndexError, KeyError) as error:
        # The readers turn bad input into messages; reaching here is a bug in fw1394.
        problem = f"{type(error).__name__}: {error}"
        raise CliError(f"{args.file}: internal error ({problem}); please report it") from None
    for line in outcome.issue_lines:
        print(f"fw1394: {args.file}: {line}", file=sys.stderr)
    hidden = outcome.issues - len(outcome.issue_lines)
    if hidden > 0:
        print(f"fw1394: {args.file}: ... and {hidden} more problems", file=sys.stderr)
    title = os.path.basename(args.file)
    try:
        if args.plot_latency:
            plot_latency(outcome.stats, args.plot_latency, title)
        if args.plot_size:
            plot_size(outcome.stats, args.plot_size, title)
    except PlotError as error:
        raise CliError(str(error)) from None
    return 0
