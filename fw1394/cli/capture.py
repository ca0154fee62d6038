"""``fw1394 capture``: record a virtual bus, or Eth1394 UDP traffic, into a trace file."""

from __future__ import annotations

import argparse
import io
import os
import signal
import sys
import threading
from collections.abc import Callable
from types import FrameType
from typing import TYPE_CHECKING, Any, BinaryIO, cast

from fw1394.cli.common import CliError

#: How long to listen for a bus's coordinator (it beacons every 0.1 s).
BUS_WAIT_S = 1.5
#: ... when this machine's runtime state says the bus is being started.
BUS_STARTING_WAIT_S = 10.0

if TYPE_CHECKING:
    from fw1394.capture.formats.bus_tap import BusTap

EPILOG = """\
examples:
  fw1394 capture -w trace.pcapng                    bus "default", until Ctrl-C
  fw1394 capture --name arm -w arm.pcapng --duration 10
  fw1394 capture -i arm -w - -c 100 -t ud           100 packets (and their acks)
  fw1394 capture --udp --interface eth0 -w boards.pcapng -c 1000
  fw1394 capture -w - | fw1394 dissect -            the trace to standard output
  fw1394 capture -w - | tshark -X lua_script:fw1394.lua -r -
  fw1394 dissect trace.pcapng                       read it back

With -w - the trace is the only thing on standard output (binary pcapng, or
pcap with --pcap); messages go to standard error. A bus capture first checks
that the bus is up (its coordinator is heard), and fails if not.

A bus trace uses fw1394's pcap link type (docs/capture-format.md); a UDP
trace holds the Ethernet frames as they were, like tcpdump would write them.
"""


def register(subparsers: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    parser = subparsers.add_parser(
        "capture",
        help="record a virtual bus (or Eth1394 UDP traffic) into a pcapng file",
        description="Record a virtual 1394 bus, or Eth1394 UDP traffic, into a trace file.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "-w", "--write", required=True, metavar="FILE", help="trace file to write; - for stdout"
    )
    parser.add_argument(
        "--name", "--bus", dest="bus", default=None, help="virtual bus name (default: default)"
    )
    parser.add_argument("--udp", action="store_true", help="capture Eth1394 UDP traffic instead")
    parser.add_argument("--port", type=int, default=1394, help="UDP port (default 1394)")
    parser.add_argument(
        "-i",
        "--interface",
        default=None,
        metavar="IFACE",
        help="as tshark -i: the bus to record (its --name), or with --udp the network "
        "interface (default lo)",
    )
    parser.add_argument("--duration", type=float, help="stop after this many seconds")
    parser.add_argument(
        "-c",
        "--count",
        type=int,
        metavar="COUNT",
        help="stop after COUNT packets (acks are not counted; those of the last packets "
        "are still written)",
    )
    parser.add_argument(
        "-t",
        "--time-format",
        choices=("r", "a", "ad", "u", "ud", "e", "d"),
        default=None,
        metavar="FORMAT",
        help="time of each line (as tshark -t): r since the first record, d since the "
        "previous, a/ad local, u/ud UTC, e seconds since 1970 (default: e in microseconds)",
    )
    parser.add_argument("-q", "--quiet", action="store_true", help="no line per packet")
    parser.add_argument("--pcap", action="store_true", help="classic pcap instead of pcapng")
    parser.set_defaults(handler=run)


def run(args: argparse.Namespace) -> int:
    from fw1394.capture.formats import live
    from fw1394.capture.formats.pcap_writer import LINKTYPE_ETHERNET, PcapngWriter, PcapWriter
    from fw1394.capture.formats.pseudo_header import LINKTYPE_FW1394

    if args.udp and args.bus:
        raise CliError("--name and --udp are two different captures: choose one")
    if not args.udp and args.interface is not None:
        if args.bus is not None and args.bus != args.interface:
            raise CliError(f"-i {args.interface} and --name {args.bus}: name the bus once")
        args.bus = args.interface
    if args.udp and args.interface is None:
        args.interface = "lo"
    if args.duration is not None and args.duration <= 0:
        raise CliError("--duration must be positive")
    if args.count is not None and args.count <= 0:
        raise CliError("--count must be positive")
    if not 0 < args.port < 65536:
        raise CliError(f"--port {args.port} is not a UDP port")
    to_stdout = args.write == "-"
    if not to_stdout and os.path.isdir(args.write):
        raise CliError(f"-w {args.write}: is a directory; name a file")
    if to_stdout and sys.stdout.isatty():
        raise CliError("-w -: standard output is a terminal; pipe it (| fw1394 dissect -)")
    container = "pcap" if args.pcap or args.write.endswith(".pcap") else "pcapng"
    linktype = LINKTYPE_ETHERNET if args.udp else LINKTYPE_FW1394
    source = _open_tap(args.bus or "default") if not args.udp else None
    try:
        stream = cast(BinaryIO, _KeepOpen(sys.stdout.buffer)) if to_stdout else _create(args.write)
    except OSError as error:
        if source is not None:
            source.close()
        raise CliError(f"{args.write}: {error.strerror or error}") from None
    writer: PcapngWriter | PcapWriter
    if container == "pcap":
        writer = PcapWriter(stream, linktype)
    else:
        description = "Eth1394 UDP" if args.udp else f"fw1394 virtual bus {args.bus or 'default'}"
        writer = PcapngWriter(
            stream,
            linktype,
            interface_name=args.interface if args.udp else "fw1394",
            description=description,
        )
    stop = threading.Event()
    previous = _stop_on_signals(stop)
    limits = live.Limits(stop, args.duration, args.count)
    # As tshark -w -: the trace owns standard output, so no line per packet.
    show = None if args.quiet or to_stdout else _printer()
    try:
        if args.udp:
            count = live.capture_udp(args.interface, (args.port,), writer, limits, show)
        else:
            assert source is not None
            with source:
                count = live.capture_records(source, writer, limits, show, _clock(args))
    except BrokenPipeError:
        # The reader went away (| head, dissect -c): stop quietly, as tshark does.
        _silence_stdout()
        return 0
    finally:
        try:
            writer.close()
        except BrokenPipeError:
            _silence_stdout()
        _restore(previous)
    where = "standard output" if to_stdout else args.write
    print(f"fw1394: {count} packets written to {where}", file=sys.stderr)
    return 0


def _clock(args: argparse.Namespace) -> Callable[[int], str] | None:
    from fw1394.capture.views.time_format import TimeColumn

    if args.time_format is None:
        return None
    column = TimeColumn(args.time_format)
    origin: list[int] = []

    def stamp(ts_ns: int) -> str:
        if not origin:
            origin.append(ts_ns)
        return column.text(ts_ns, origin[0]).strip()

    return stamp


def _create(path: str) -> BinaryIO:
    return open(path, "wb")


class _KeepOpen(io.BufferedIOBase):
    """Standard output for the trace writer: closing it flushes, stdout stays open."""

    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream

    def writable(self) -> bool:
        return True

    def write(self, data: Any) -> int:
        return self._stream.write(data)

    def flush(self) -> None:
        self._stream.flush()

    def close(self) -> None:
        self._stream.flush()


def _silence_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    os.close(devnull)


def _open_tap(bus: str) -> BusTap:
    """A tap on ``bus``, once its coordinator has been heard (no bus: a one-line error)."""
    from fw1394.capture.formats.bus_tap import BusTap
    from fw1394.transport.supervision.observe import watch
    from fw1394.transport.supervision.runtime import bus_dir, supervisor_alive

    try:
        tap = BusTap(bus)
    except (OSError, ValueError) as error:
        raise CliError(f"cannot tap bus {bus!r}: {error}") from None
    # The tap listens already, so nothing sent while we look for a beacon is lost.
    starting = supervisor_alive(bus_dir(bus)) is not None
    wait = BUS_STARTING_WAIT_S if starting else BUS_WAIT_S
    try:
        if watch(tap.config, wait) is None:
            raise CliError(
                f"no bus {bus!r} is running (no coordinator heard in {wait:g} s); "
                f"start one with: fw1394 bus up --name {bus}"
            )
    except BaseException:
        tap.close()
        raise
    return tap


def _printer() -> Callable[[str], None]:
    def show(line: str) -> None:
        print(line, flush=True)

    return show


Handlers = dict[int, Callable[[int, FrameType | None], object] | int | None]


def _stop_on_signals(stop: threading.Event) -> Handlers:
    def handler(number: int, frame: FrameType | None) -> None:
        stop.set()

    previous: Handlers = {}
    for number in (signal.SIGINT, signal.SIGTERM):
        previous[number] = signal.signal(number, handler)
    return previous


def _restore(previous: Handlers) -> None:
    for number, handler in previous.items():
        signal.signal(number, handler)
