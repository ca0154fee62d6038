"""``fw1394 jhu``: emulated JHU FPGA1394/QLA boards over Eth1394, and a host to test them.

``serve`` runs boards in this process behind loopback UDP sockets; ``scan``,
``quad``, ``block`` and ``rt`` act as the JHU host library does (start-up scan
first, as every JHU host program does), against fw1394 boards or anything
else that speaks Eth1394 on loopback.
"""

from __future__ import annotations

import argparse
import gc
import signal
import sys
from types import FrameType
from typing import Any

from fw1394.cli.common import CliError, integer, print_json, print_table
from fw1394.errors import Error

EXAMPLES = """\
examples:
  sudo fw1394 jhu serve --boards 4             4 QLA boards, firmware 8 (bridge), port 1394
  fw1394 jhu serve --boards 2 --eth1394 127.0.0.1:11394     unprivileged port
  fw1394 jhu scan -p udp:127.0.0.1:11394       the host's start-up scan
  fw1394 jhu quad -p udp:127.0.0.1:11394 -b 0 4          read HARDWARE_VERSION of board 0
  fw1394 jhu rt -p udp:127.0.0.1:11394 --cycles 1000     the host's real-time loop
firmware >= 9 (Ethernet-only mode, multicast) only inside a network namespace:
  ip netns add qla; ip -n qla link set lo up; ip -n qla route add 224.0.0.0/4 dev lo
  ip netns exec qla fw1394 jhu serve --boards 4 --firmware 9
  (the real host's multicasts then come from 0.0.0.0, this host: answered like the
  firmware answers any source address)
replies that cannot be sent are reported once per cause on stderr; SIGTERM/SIGINT
stop the server at once.
"""


def register(subparsers: Any) -> None:
    jhu = subparsers.add_parser(
        "jhu",
        help="JHU FPGA1394/QLA boards over Eth1394 (UDP port 1394)",
        description=__doc__,
        epilog=EXAMPLES,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    actions = jhu.add_subparsers(dest="action", metavar="ACTION", required=True)
    serve = actions.add_parser("serve", help="serve emulated boards on loopback UDP")
    serve.add_argument("--boards", type=int, default=1, help="boards 0..N-1 (default 1)")
    serve.add_argument("--board-ids", default=None, help="comma-separated board IDs instead")
    serve.add_argument("--firmware", type=int, default=8, help="firmware revision (default 8)")
    serve.add_argument("--fpga-version", type=int, default=3, choices=(1, 2, 3))
    serve.add_argument(
        "--eth1394",
        default="127.0.0.1",
        metavar="ADDRESS[:PORT]",
        help="server IP the host is given (loopback only) and UDP port (default 1394)",
    )
    serve.add_argument(
        "--git-description", type=integer, default=0, help="GIT_DESC register (default 0)"
    )
    serve.add_argument("--duration", type=float, default=None, help="stop after this many s")
    serve.add_argument(
        "--reuse-port",
        action="store_true",
        help="share the port with a server that already holds it (both then get the "
        "host's datagrams); without it, a port in use is refused, naming its holder",
    )
    serve.set_defaults(handler=run_serve)
    for name, text in (
        ("scan", "the host's start-up scan"),
        ("quad", "read or write one quadlet, as quad1394eth does"),
        ("block", "read or write a block, as block1394eth does"),
        ("rt", "the host's real-time loop"),
    ):
        sub = actions.add_parser(name, help=text)
        sub.add_argument(
            "-p",
            "--port",
            dest="port_spec",
            default="udp:127.0.0.1",
            help="udp:IP[:PORT] or udpfw:IP[:PORT] (udpfw forces bridge mode)",
        )
        sub.add_argument("--json", action="store_true", help="JSON output")
        sub.add_argument("-v", "--verbose", action="store_true", help="print the host's log")
        sub.add_argument(
            "--receive-timeout",
            type=float,
            default=0.020,
            metavar="SECONDS",
            help="how long each read waits for its answer (default 0.020, as the JHU "
            "host library; raise it on a loaded machine)",
        )
        if name in ("quad", "block"):
            sub.add_argument("-b", "--board", type=int, default=0, help="board ID (default 0)")
            sub.add_argument("address", type=integer, help="register offset (quadlet index)")
        if name == "quad":
            sub.add_argument("value", type=integer, nargs="?", help="write this value")
        if name == "block":
            sub.add_argument("count", type=integer, help="quadlets")
            sub.add_argument("data", type=integer, nargs="*", help="quadlets to write")
        if name == "rt":
            sub.add_argument(
                "--cycles",
                type=int,
                default=100,
                help="loop cycles (default 100); each 50 are followed by 50 raw UDP "
                "ping-pongs to the first board, the machine's floor, reported beside",
            )
            sub.add_argument(
                "--protocol", choices=("sequential", "broadcast-write", "broadcast-read-write")
            )
        sub.set_defaults(handler=run_host, action_name=name)


def run_serve(args: argparse.Namespace) -> int:
    from fw1394.boards.qla1.eth_server import Eth1394Server
    from fw1394.boards.qla1.rack import Rack
    from fw1394.transport.eth1394_addresses import parse_endpoint
    from fw1394.transport.udp_ports import PortInUseError

    endpoint = parse_endpoint(args.eth1394)
    try:
        ids = (
            [int(part) for part in args.board_ids.split(",")]
            if args.board_ids
            else list(range(args.boards))
        )
    except ValueError:
        raise CliError(f"--board-ids {args.board_ids}: give numbers, as 0,1,2") from None
    try:
        rack = Rack(
            ids,
            firmware=args.firmware,
            fpga_version=args.fpga_version,
            git_description=args.git_description,
        )
    except ValueError as error:  # the rack's plain ValueError: no boards, a repeated ID
        raise CliError(str(error)) from None
    try:
        server = Eth1394Server(rack, endpoint, share_port=args.reuse_port)
    except PortInUseError:
        raise  # names the port and its holder already
    except PermissionError:
        raise CliError(
            f"cannot bind UDP port {endpoint.port}: run as root, grant CAP_NET_BIND_SERVICE "
            "(setcap cap_net_bind_service=+ep on the Python binary), or pick another port "
            "with --eth1394 127.0.0.1:PORT"
        ) from None
    except OSError as error:
        raise CliError(f"cannot open the Eth1394 sockets: {error}") from None
    mode = "Ethernet-only capable" if args.firmware >= 9 else "bridge"
    print(
        f"fw1394 jhu: {len(ids)} QLA boards {ids}, firmware {args.firmware} ({mode}), "
        f"on {', '.join(server.addresses)}",
        file=sys.stderr,
        flush=True,
    )

    def stop(signum: int, frame: FrameType | None) -> None:
        # Raised inside select(): the loop ends at once, not at its next timeout.
        raise _Stopped

    # Everything built so far lives as long as the process: keeping it out of the
    # collector makes the exit after SIGTERM quick (no final sweep over it).
    gc.freeze()
    previous = {sig: signal.signal(sig, stop) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        with server:
            if args.duration is None:
                server.serve_forever()
            else:
                server.serve_for(args.duration)
    except _Stopped:
        pass
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
    stats = server.stats
    print(
        f"fw1394 jhu: stopped after {stats.received} requests, {stats.sent} replies sent, "
        f"{stats.refused} refused",
        file=sys.stderr,
    )
    return 0


class _Stopped(Error):
    """SIGTERM or SIGINT ended ``jhu serve``."""


def _client(args: argparse.Namespace) -> Any:
    from fw1394.jhu.client import EthUdpClient
    from fw1394.transport.eth1394_addresses import parse_endpoint

    kind, _, rest = args.port_spec.partition(":")
    if kind not in ("udp", "udpfw"):
        raise CliError(f"-p {args.port_spec}: only udp:IP[:PORT] and udpfw:IP[:PORT]")
    if not 0 < args.receive_timeout <= 10:
        raise CliError(f"--receive-timeout {args.receive_timeout}: use 0 to 10 seconds")
    endpoint = parse_endpoint(rest)
    logger = (lambda text: print(text, file=sys.stderr)) if args.verbose else None
    try:
        return EthUdpClient(
            endpoint,
            force_bridge=kind == "udpfw",
            receive_timeout=args.receive_timeout,
            log=logger,
        )
    except OSError as error:  # no loopback to send on (a namespace with lo down)
        raise CliError(f"-p {args.port_spec}: {error.strerror or error}") from None


def run_host(args: argparse.Namespace) -> int:
    from fw1394.jhu.scan import start

    with _client(args) as client:
        scan = start(client)
        if not scan.ok:
            raise CliError("no boards found (run with -v to see the host's log)")
        if args.action_name == "scan":
            return _print_scan(scan, args.json)
        if args.action_name == "rt":
            return _run_rt(client, scan, args)
        return _run_access(client, scan, args)


def _scan_summary(scan: Any) -> dict[str, Any]:
    """What the start-up scan found, as ``jhu scan --json`` prints it."""
    rows = [
        {
            "node": b.node,
            "board_id": b.board_id,
            "hardware": b.hardware.to_bytes(4, "big").decode("ascii", "replace"),
            "firmware": b.firmware,
            "fpga": b.fpga_version,
        }
        for b in scan.boards
    ]
    mode = "bridge" if scan.bridge else "ethernet-only"
    return {"mode": mode, "hub_board": scan.hub_board, "boards": rows}


def _print_scan(scan: Any, as_json: bool) -> int:
    summary = _scan_summary(scan)
    if as_json:
        print_json(summary)
        return 0
    mode, rows = summary["mode"], summary["boards"]
    print(f"mode {mode}, hub board {scan.hub_board}, protocol {scan.protocol.value}")
    table: list[tuple[str, ...]] = [("NODE", "BOARD", "HARDWARE", "FIRMWARE", "FPGA")]
    table += [tuple(str(row[key]) for key in ("node", "board_id", "hardware", "firmware", "fpga"))
              for row in rows]  # fmt: skip
    print_table(table, indent="")
    return 0


def _run_access(client: Any, scan: Any, args: argparse.Namespace) -> int:
    try:
        node = scan.node_of(args.board)
    except KeyError as error:
        raise CliError(str(error.args[0])) from None
    if args.action_name == "quad":
        if args.value is not None:
            client.write_quadlet_node(node, args.address, args.value & 0xFFFFFFFF)
            return 0
        value = client.read_quadlet_node(node, args.address)
        if value is None:
            raise CliError("ReadQuadlet Failed")
        if args.json:
            print_json({"value": value})
        else:
            print(f"0x{value:08x}")
        return 0
    if args.data:
        data = b"".join((v & 0xFFFFFFFF).to_bytes(4, "big") for v in args.data[: args.count])
        if not client.write_block_node(node, args.address, data):
            raise CliError("WriteBlock Failed")
        return 0
    block = client.read_block_node(node, args.address, 4 * args.count)
    if block is None:
        raise CliError("ReadBlock Failed")
    words = [int.from_bytes(block[n : n + 4], "big") for n in range(0, len(block), 4)]
    if args.json:
        print_json({"quadlets": words})
    else:
        for word in words:
            print(f"0x{word:08x}")
    return 0


def _run_rt(client: Any, scan: Any, args: argparse.Namespace) -> int:
    from fw1394.jhu.hub_parse import MixedFirmwareError
    from fw1394.jhu.rt_loop import RealTimeLoop, measure
    from fw1394.jhu.scan import Protocol

    if args.cycles < 1:
        raise CliError(f"--cycles {args.cycles}: give 1 or more")
    protocol = Protocol(args.protocol) if args.protocol else None
    try:
        loop = RealTimeLoop(client, scan, protocol)
    except MixedFirmwareError as error:
        raise MixedFirmwareError(f"--protocol {args.protocol}: {error}") from None
    # Everything the loop needs exists now and lives to the end: kept out of the
    # collector's sweeps, which each cycle's short-lived objects keep triggering.
    gc.freeze()
    report = measure(loop, args.cycles).as_dict()
    if args.json:
        # The scan it began with too: a script needs no second scan to know the boards.
        print_json({**report, "scan": _scan_summary(scan)})
    else:
        print(
            f"{report['cycles']} cycles ({report['protocol']}, {report['boards']} boards): "
            f"{report['complete']} complete, {report['mean_cycle_ms']:.3f} ms per cycle "
            f"({report['loop_hz']:.0f} Hz); raw UDP ping-pong {report['ping_pong_ms']:.3f} ms "
            f"({report['ping_pong_hz']:.0f} Hz); client CPU "
            f"{report['client_cpu_ms_per_cycle']:.3f} ms per cycle; load {report['load_1min']:.1f}"
        )
    return 0 if report["complete"] == report["cycles"] else 1
