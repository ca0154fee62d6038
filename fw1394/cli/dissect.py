"""``fw1394 dissect``: read a 1394 trace and show its packets, transactions or statistics."""

from __future__ import annotations

import argparse
import os
import sys
from typing import TYPE_CHECKING, Any

from fw1394.cli.common import WRITE_ERRNOS, CliError, integer
from fw1394.packets.nodeid import node_id

if TYPE_CHECKING:
    from fw1394.capture.formats.sources import PortTally
    from fw1394.capture.views.dissection import Outcome

EPILOG = """\
formats (detected, or named with --format):
  fw1394   fw1394's own pcap/pcapng (fw1394 capture)
  udp      pcap/pcapng of UDP port 1394 (JHU Eth1394), from tcpdump or Wireshark
  nosy     nosy-dump --output files
  kernel   Linux kernel text: firewire tracepoints, firewire-ohci debug lines

display filter (-Y): Wireshark's language with the field names the Lua
dissector registers (`fw1394 wireshark-dissector`), so a filter runs in both
(fw1394.tcode, or tcode for short): == != < <= > >=, && and, || or, ! not,
parentheses, in {{4, 5, 8..10}}, contains and matches on fw1394.kind and
fw1394.data, integers (12, 0x1f), value names (read_quadlet_request,
resp_complete, ack_pending), times in seconds as tshark writes them
(fw1394.response_time > 0.0002) or with a unit (200us, 1.5ms). A field
missing from a row fails every comparison. Fields (docs/dissect.md has more):
{fields}

examples:
  fw1394 dissect trace.pcapng
  fw1394 dissect trace.pcapng --transactions --node 2 --tcode read_block_request
  fw1394 dissect trace.pcapng -Y 'tcode == read_quadlet_request && dst == 0xffc1'
  fw1394 dissect trace.pcapng --transactions -Y 'rcode != resp_complete || latency > 100us'
  fw1394 dissect trace.pcapng -Y 'fw1394.header_crc.status == 0 || fw1394.response_time > 0.0002'
  fw1394 dissect trace.pcapng -t ud -c 20             first 20 packets, UTC times
  fw1394 capture -w - -c 100 | fw1394 dissect -       from a pipe
  fw1394 dissect dmesg.txt --stats --json
  fw1394 dissect trace.pcapng --plot-latency latency.png --plot-size size.png

exit status: 0 when records were read (even if none matched), 2 when the
input is unreadable, nothing in it was recognised, or it was cut short
(what was read before is still shown, as tshark does).
"""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    from fw1394.capture.views.display_filter import help_lines
    from fw1394.capture.views.time_format import FORMATS

    parser = subparsers.add_parser(
        "dissect",
        help="show the packets, transactions or statistics of a trace",
        description="Read a 1394 trace and show its packets, transactions, statistics or ROMs.",
        epilog=EPILOG.format(fields="\n".join(help_lines())),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("file", nargs="?", help="trace file, or - for standard input")
    parser.add_argument(
        "-r", "--read-file", metavar="FILE", help="trace file, or - for standard input (as tshark)"
    )
    parser.add_argument(
        "-Y",
        "--display-filter",
        metavar="EXPR",
        help="show only packets (or transactions) matching EXPR, e.g. 'tcode == 4 && rcode != 0'",
    )
    parser.add_argument(
        "-c",
        "--count",
        type=positive,
        metavar="COUNT",
        help="read only the first COUNT records (as tshark -r -c), whatever the view",
    )
    parser.add_argument(
        "-t",
        "--time-format",
        choices=tuple(FORMATS),
        default="r",
        metavar="FORMAT",
        help="time column: " + "; ".join(f"{k} {v}" for k, v in FORMATS.items()),
    )
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
    parser.add_argument(
        "-v", "-V", "--verbose", action="store_true", help="every field of every packet (tshark -V)"
    )
    parser.add_argument("-x", "--hex", action="store_true", help="each packet's bytes (tshark -x)")
    parser.add_argument(
        "-l", "--line-buffered", action="store_true", help="flush after each packet (tshark -l)"
    )
    output = parser.add_mutually_exclusive_group()
    output.add_argument("--json", action="store_true", help="one JSON object per line")
    output.add_argument("--csv", action="store_true", help="comma-separated values with a header")
    output.add_argument(
        "-T",
        choices=("text", "fields", "json", "ek"),
        dest="output_format",
        metavar="FORMAT",
        help="as tshark -T: text, fields (with -e), json (one array) or ek (one object a line)",
    )
    parser.add_argument(
        "-e",
        action="append",
        default=[],
        dest="fields",
        metavar="FIELD",
        help="with -T fields: a field to print (Wireshark's name, e.g. fw1394.tcode); repeat",
    )
    parser.add_argument(
        "-E",
        action="append",
        default=[],
        dest="field_options",
        metavar="OPTION",
        help="with -T fields: separator=C (default a tab), header=y",
    )
    parser.add_argument(
        "-z",
        action="append",
        default=[],
        dest="statistics",
        metavar="STAT",
        choices=("expert", "conv", "latency", "fw1394.latency"),
        help="as tshark -z, after the packets: expert (problems), conv (node to node), "
        "latency (transaction times by kind and node); repeat",
    )
    parser.add_argument(
        "-q", "--quiet", action="store_true", help="no packet rows (with -z: only statistics)"
    )
    parser.add_argument(
        "-w",
        "--write",
        metavar="FILE",
        help="write the packets shown (-Y ...) to a pcapng trace instead, each with its ack",
    )
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


def positive(text: str) -> int:
    """argparse type: an integer above zero."""
    value = integer(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"{text!r} is not above zero")
    return value


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
        from fw1394.capture.views.display_filter import DisplayFilter
        from fw1394.capture.views.dissection import Dissection, Options, pair_links
        from fw1394.capture.views.trace_plots import (
            PlotError,
            check_plot_path,
            plot_latency,
            plot_size,
            require_matplotlib,
        )
    except ImportError as error:
        # numpy carries the bulk path; without it there is nothing to dissect with.
        raise CliError(f"fw1394 dissect needs {error.name}: pip install {error.name}") from None

    path = _input_path(args)
    plots = args.plot_latency or args.plot_size
    if plots:
        require_matplotlib()
    for option, target in (("--plot-latency", args.plot_latency), ("--plot-size", args.plot_size)):
        if target is None:
            continue
        if os.path.isdir(target):
            raise CliError(f"{option} {target}: is a directory; name a PNG file")
        parent = os.path.dirname(target) or "."
        if not os.path.isdir(parent):
            raise CliError(f"{option} {target}: directory {parent} does not exist")
        try:
            check_plot_path(target)
        except PlotError as error:  # the same kind, naming the option
            raise PlotError(f"{option} {error}") from None
    for node in args.node:
        if not 0 <= node <= 0xFFFF:
            raise CliError(
                f"--node {node} is not a node: give a PHY ID 0..63 or a node ID such as 0xffc2"
            )
    for option, seconds in (("--since", args.since), ("--until", args.until)):
        if seconds is not None and not seconds >= 0:
            raise CliError(f"{option} {seconds:g}: give seconds after the first record, 0 or more")
    if args.since is not None and args.until is not None and args.since > args.until:
        raise CliError(
            f"--since {args.since:g} is after --until {args.until:g}: no record can be in between"
        )
    if args.threads < 1:
        raise CliError("--threads must be at least 1")
    if not 0 < args.port < 65536:
        raise CliError(f"--port {args.port} is not a UDP port")
    display_filter = None
    if args.display_filter is not None:
        if args.view not in ("packets", "transactions"):
            raise CliError("-Y filters the packet and transaction views, not --" + args.view)
        display_filter = DisplayFilter(args.display_filter, args.view)
    links = None
    if display_filter is not None and args.view == "packets":
        from fw1394.capture.views.display_filter import LINK_FIELDS

        linked = sorted(display_filter.fields & LINK_FIELDS)
        if linked and path == sources.STDIN:
            raise CliError(
                f"-Y on {', '.join(linked)} pairs the whole trace before showing a packet: "
                "give a file, not standard input (or filter --transactions)"
            )
        if linked:
            fmt = sources.detect(path) if args.format == "auto" else args.format
            links = pair_links(
                sources.jobs(path, fmt, sources.PortTally((args.port,))),
                True if args.verify_crc else None,
                args.threads,
            )
    output, fields, separator, header = _output_format(args)
    if output == "fields":
        from fw1394.capture.views.display_filter import LINK_FIELDS, field_name

        for name in fields:
            if field_name(name) is None:
                raise CliError(
                    f"-e {name}: unknown field (fw1394 dissect --help lists them; "
                    "Wireshark's names such as fw1394.tcode or frame.number)"
                )
        if links is None and {field_name(n) for n in fields} & LINK_FIELDS:
            if path == sources.STDIN:
                raise CliError("-e on frame links pairs the whole trace first: give a file")
            fmt = sources.detect(path) if args.format == "auto" else args.format
            links = pair_links(
                sources.jobs(path, fmt, sources.PortTally((args.port,))), None, args.threads
            )
        if header:
            print(separator.join(fields))
    writer = _trace_writer(args)
    options = Options(
        view=args.view,
        output=output,
        fields=tuple(fields),
        separator=separator,
        hex_dump=args.hex,
        flush_each=args.line_buffered,
        writer=writer,
        statistics=tuple("latency" if z == "fw1394.latency" else z for z in args.statistics),
        quiet=args.quiet,
        verbose=args.verbose,
        nodes=frozenset(args.node),
        tcodes=tcode_values(args.tcode),
        since_s=args.since,
        until_s=args.until,
        verify_crc=True if args.verify_crc else None,
        workers=args.threads,
        want_plots=bool(plots),
        display_filter=display_filter,
        count=args.count,
        time_format=args.time_format,
        links=links,
    )
    name = "standard input" if path == sources.STDIN else path
    ports = sources.PortTally((args.port,))
    try:
        if path == sources.STDIN and args.format != "auto":
            fmt = args.format  # nothing to look at first: a live log is read as it comes
            jobs = sources.stream_jobs(sys.stdin.buffer, fmt, ports)
        elif path == sources.STDIN:
            stream, head = sources.open_stream(sys.stdin.buffer)
            fmt = sources.detect_head(head, name)
            jobs = sources.stream_jobs(stream, fmt, ports)
        else:
            fmt = sources.detect(path) if args.format == "auto" else args.format
            jobs = sources.jobs(path, fmt, ports)
        if output == "json-array":
            outcome = _json_array(Dissection, options, jobs)
        else:
            outcome = Dissection(options, sys.stdout).run(jobs)
        if writer is not None:
            writer.close()
    except sources.SourceError:
        raise  # bad input, one line from fw1394.cli.main; not a bug like the ValueErrors below
    except MemoryError:
        raise CliError("out of memory") from None
    except OSError as error:
        if error.errno not in WRITE_ERRNOS:
            raise CliError(f"{name}: {error.strerror or error}") from None
        raise  # the output's failure, reported once for every command
    except (ValueError, RuntimeError, IndexError, KeyError) as error:
        # The readers turn bad input into messages; reaching here is a bug in fw1394.
        problem = f"{type(error).__name__}: {error}"
        raise CliError(f"{name}: internal error ({problem}); please report it") from None
    sys.stdout.flush()
    for line in outcome.issue_lines:
        print(f"fw1394: {name}: {line}", file=sys.stderr)
    hidden = outcome.issues - len(outcome.issue_lines)
    if hidden > 0:
        print(f"fw1394: {name}: ... and {hidden} more problems", file=sys.stderr)
    if outcome.cut_short:
        raise CliError(
            f"{name} appears to have been cut short in the middle of a record "
            f"({outcome.records} records read before it)"
        )
    if not outcome.records:
        return _nothing_read(name, fmt, args.port, ports)
    chosen = _selection(args)
    if chosen and args.view in ("packets", "transactions") and not outcome.shown:
        what = "transaction" if args.view == "transactions" else "record"
        print(
            f"fw1394: {name}: no {what} matched {chosen} ({outcome.records} records read"
            f"{_span(outcome)})",
            file=sys.stderr,
        )
    title = os.path.basename(path) if path != sources.STDIN else "stdin"
    if args.plot_latency:
        plot_latency(outcome.stats, args.plot_latency, title)
    if args.plot_size:
        plot_size(outcome.stats, args.plot_size, title)
    return 0


def _output_format(args: argparse.Namespace) -> tuple[str, list[str], str, bool]:
    """The output kind (text, json, csv, fields, json-array), -e fields, -E options."""
    kind = args.output_format
    if args.fields and kind != "fields":
        raise CliError("-e names fields of -T fields: add -T fields")
    if args.field_options and kind != "fields":
        raise CliError("-E sets options of -T fields: add -T fields")
    separator, header = "\t", False
    for option in args.field_options:
        key, _, value = option.partition("=")
        if key == "separator" and value:
            named = {"/t": "\t", "/s": " ", "\\t": "\t"}
            separator = named.get(value, value)
        elif key == "header" and value in ("y", "n"):
            header = value == "y"
        else:
            raise CliError(f"-E {option}: use separator=C or header=y|n")
    if kind == "fields":
        if not args.fields:
            raise CliError("-T fields needs at least one -e FIELD (e.g. -e frame.number)")
        if args.view != "packets":
            raise CliError("-T fields prints packets: drop --" + args.view)
        return "fields", list(args.fields), separator, header
    if kind == "json":
        return "json-array", [], separator, header
    if kind == "ek" or args.json:
        return "json", [], separator, header
    return ("csv" if args.csv else "text"), [], separator, header


def _trace_writer(args: argparse.Namespace) -> Any:
    """-w FILE: a pcapng writer in fw1394's link type, or None."""
    if args.write is None:
        return None
    if args.view != "packets":
        raise CliError("-w saves packets: drop --" + args.view)
    if args.write == "-" and sys.stdout.isatty():
        raise CliError("-w -: standard output is a terminal; pipe it or name a file")
    from fw1394.capture.formats.pcap_writer import PcapngWriter
    from fw1394.capture.formats.pseudo_header import LINKTYPE_FW1394

    try:
        stream = sys.stdout.buffer if args.write == "-" else open(args.write, "wb")  # noqa: SIM115
    except OSError as error:
        raise CliError(f"-w {args.write}: {error.strerror or error}") from None
    return PcapngWriter(stream, LINKTYPE_FW1394, description="fw1394 dissect -w")


def _json_array(dissection: Any, options: Any, jobs: Any) -> Any:
    """tshark -T json: the packets' objects as one JSON array."""
    import io

    buffer = io.StringIO()
    options.output = "json"
    outcome = dissection(options, buffer).run(jobs)
    rows = buffer.getvalue().splitlines()
    sys.stdout.write("[\n" + ",\n".join(f"  {row}" for row in rows) + ("\n]\n" if rows else "]\n"))
    return outcome


def _selection(args: argparse.Namespace) -> str:
    """The options that choose rows, as the user gave them."""
    parts = [f"--node {node}" for node in args.node]
    parts += [f"--tcode {tcode}" for tcode in args.tcode]
    if args.since is not None:
        parts.append(f"--since {args.since:g}")
    if args.until is not None:
        parts.append(f"--until {args.until:g}")
    if args.display_filter is not None:
        parts.append(f"-Y {args.display_filter!r}")
    return " ".join(parts)


def _span(outcome: Outcome) -> str:
    """What the trace held that a selection could have matched: its nodes and length."""
    nodes = sorted(outcome.nodes_seen)
    text = f", spanning {outcome.duration_s:.6g} s" if outcome.duration_s is not None else ""
    if nodes:
        text += "; nodes in it: " + ", ".join(f"{n} ({node_id(n):#06x})" for n in nodes)
    return text


_FORMAT_NAMES = {"kernel": "Linux kernel firewire text", "nosy": "nosy-dump records"}


def _input_path(args: argparse.Namespace) -> str:
    if args.file is not None and args.read_file is not None:
        raise CliError(f"two traces given ({args.file} and -r {args.read_file}): give one")
    path: str | None = args.file if args.file is not None else args.read_file
    if path is None:
        raise CliError("no trace given: name a file (or -r FILE), or - for standard input")
    if path == "-":
        if sys.stdin.isatty():
            raise CliError("standard input is a terminal: pipe a trace into fw1394 dissect -")
        return path
    if os.path.isdir(path):
        raise CliError(f"{path}: is a directory, not a trace")
    if not os.path.isfile(path):
        raise CliError(f"{path}: no such file")
    return path


def _nothing_read(name: str, fmt: str, port: int, ports: PortTally) -> int:
    """Explain an input that gave no records; 0 only for a valid, empty fw1394 trace."""
    if fmt == "fw1394":
        print(f"fw1394: {name}: the trace holds no packets", file=sys.stderr)
        return 0
    if fmt == "udp":
        message = f"{name}: 0 Eth1394 datagrams found on UDP port {port}"
        busiest = ports.busiest()
        if busiest:
            seen = ", ".join(str(p) for p in busiest)
            message += f"; there is UDP traffic on port {seen}: try --port {busiest[0]}"
        else:
            message += " and no UDP traffic on other ports; name the port with --port"
        raise CliError(message)
    raise CliError(
        f"{name}: nothing recognised as {_FORMAT_NAMES.get(fmt, fmt)} (0 records); "
        "check the file, or name its format with --format"
    )
