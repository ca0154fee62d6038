"""``fw1394 read|write|lock``: one transaction on a virtual bus, as its host.

The command runs the transaction through the bus's host adapter (the bus's
PC, shared by every program: no bus reset), or with ``--own-member`` joins
the bus as a host of its own (one bus reset to join, another to leave), as
plugging a second PC into the cable would.
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from fw1394.cli.attach import add_attach_options, host_member, open_port, port_errors
from fw1394.cli.bus import add_bus_options, add_member_options, bus_config
from fw1394.cli.common import CliError, fail, integer
from fw1394.errors import Error
from fw1394.packets import ExtendedTCode, RCode, name_of
from fw1394.packets.hextext import quadlets_hex
from fw1394.packets.nodeid import BROADCAST_PHY

LOCK_OPERATIONS = {
    name: int(ExtendedTCode[name])
    for name in (
        "mask_swap",
        "compare_swap",
        "fetch_add",
        "little_add",
        "bounded_add",
        "wrap_add",
    )
}
_NO_ARGUMENT = ("fetch_add", "little_add")
EXAMPLES = {
    "read": "examples:\n  fw1394 read 0 0x0\n  fw1394 read 1 0x100 --length 2048 --json\n",
    "write": "examples:\n  fw1394 write 0 0x8 0x12345678\n  fw1394 write 2 0x100 1 2 3 4\n",
    "lock": (
        "examples:\n  fw1394 lock 0 0x10 compare_swap 0x0 0x1   (argument, then data)\n"
        "  fw1394 lock 0 0x10 fetch_add 0x1\n"
    ),
}


def register(subparsers: Any) -> None:
    read = _parser(subparsers, "read", "read a quadlet or a block from a node")
    read.add_argument(
        "--length",
        type=integer,
        default=4,
        help="bytes (4: quadlet read; longer: a block read, at most what one datagram carries)",
    )
    read.set_defaults(handler=run_read)
    write = _parser(subparsers, "write", "write quadlets to a node")
    write.add_argument("values", nargs="+", type=integer, metavar="VALUE", help="quadlets")
    write.add_argument("--block", action="store_true", help="block write even for one quadlet")
    write.set_defaults(handler=run_write)
    lock = _parser(subparsers, "lock", "lock transaction (atomic read-modify-write)")
    lock.add_argument("operation", choices=sorted(LOCK_OPERATIONS), metavar="OPERATION")
    lock.add_argument("operands", nargs="+", type=integer, metavar="QUADLET")
    lock.set_defaults(handler=run_lock)


def _parser(subparsers: Any, name: str, text: str) -> argparse.ArgumentParser:
    parser: argparse.ArgumentParser = subparsers.add_parser(
        name,
        help=text + " on a virtual bus",
        description=text.capitalize() + " on a virtual 1394 bus, as a host.",
        epilog=EXAMPLES[name],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("node", type=integer, metavar="NODE", help="physical ID (0-62)")
    parser.add_argument("offset", type=integer, metavar="OFFSET", help="48-bit address offset")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--timeout",
        type=float,
        default=1.0,
        help="ack and response timeout (s) of --own-member (the adapter keeps its own)",
    )
    add_attach_options(parser)
    add_bus_options(parser)
    add_member_options(parser)
    return parser


def _check(args: argparse.Namespace) -> None:
    if not 0 <= args.offset < 1 << 48:
        raise CliError(f"offset {args.offset:#x} does not fit 48 bits")
    if not 0 <= args.node <= BROADCAST_PHY:
        raise CliError(f"node {args.node} is not a physical ID (0-62, 63 is broadcast)")
    if args.timeout <= 0:
        raise CliError(f"--timeout {args.timeout} must be positive")


def _quadlet(value: int) -> bytes:
    if not 0 <= value < 1 << 32:
        raise CliError(f"{value:#x} does not fit a quadlet (32 bits)")
    return value.to_bytes(4, "big")


def _transact(args: argparse.Namespace, what: str, action: Any) -> Any:
    """Reach the bus, check the node is there, run ``action(port)``, let go."""
    from fw1394.transport.bus_host import TransactionError

    _check(args)
    config = bus_config(args)
    reaching: tuple[type[Exception], ...] = (*port_errors(), ValueError)
    with open_port(args) as port:
        try:
            nodes = dict(port.nodes())
            if args.node != BROADCAST_PHY and args.node not in nodes:
                known = ", ".join(str(phy) for phy in sorted(nodes)) or "none"
                raise CliError(
                    f"no node {args.node} on bus {config.name!r} (nodes: {known}; "
                    "is it up? fw1394 bus up --nodes N)"
                )
            return action(port)
        except reaching as error:  # ValueError: a block too long for this bus
            raise CliError(str(error)) from None
        except TransactionError as error:
            failure = {"reason": str(error.reason)}
            if error.failure.rcode is not None:
                failure["rcode"] = name_of(RCode, error.failure.rcode)
            if error.failure.detail:
                failure["detail"] = error.failure.detail
            message = f"{what} of node {args.node} at {args.offset:#x}: {error}"
            why = _why_unanswered(args, port, nodes, what, error)
            if why:
                # The board's kind rules the "outcome unknown" out: it never performs these.
                failure["explanation"] = why
                message = f"{what} of node {args.node} at {args.offset:#x}: {error.reason}: {why}"
            raise _Failed(message, failure) from None


def _why_unanswered(
    args: argparse.Namespace, port: Any, nodes: dict[int, Any], what: str, error: Any
) -> str | None:
    """What the node's board kind says about a request it did not answer."""
    from fw1394.engine import FailureReason
    from fw1394.host.explain import unserved
    from fw1394.packets import TCode
    from fw1394.watch.detect import member_kind

    unanswered = (FailureReason.no_ack, FailureReason.ack_type_error)
    member = nodes.get(args.node)
    if error.reason not in unanswered or member is None or what not in _TCODE_OF:
        return None
    kind = member_kind(args.name, host_member(port), member)
    return unserved(kind, TCode[_TCODE_OF[what]])


#: The request tcode each command sends (reads and writes: either size is served alike).
_TCODE_OF = {
    "read": "read_quadlet_request",
    "write": "write_quadlet_request",
    "lock": "lock_request",
}


class _Failed(Error):
    """A transaction that failed on the bus (exit status 1, not a usage error)."""

    def __init__(self, message: str, failure: dict[str, str]) -> None:
        super().__init__(message)
        self.failure = failure


def _failed(args: argparse.Namespace, error: _Failed) -> int:
    # Scripts asking for JSON get the failure as JSON on stdout too, not only the
    # line on stderr: {"node": 0, "offset": 3, "error": {"reason": ..., "rcode": ...}}.
    if args.json:
        print(json.dumps({"node": args.node, "offset": args.offset, "error": error.failure}))
    return fail(str(error), 1)


def _report(args: argparse.Namespace, result: dict[str, Any], text: str) -> None:
    print(json.dumps(result) if args.json else text)


def run_read(args: argparse.Namespace) -> int:
    from fw1394.transport.bus_host import MAX_BLOCK_READ

    if not 0 < args.length <= MAX_BLOCK_READ:
        # The 1394 field allows 65535, but the answer must fit one datagram.
        raise CliError(f"--length {args.length} is outside 1..{MAX_BLOCK_READ}")
    if args.node == BROADCAST_PHY:
        raise CliError("reads cannot be broadcast (node 63)")

    def action(port: Any) -> bytes:
        if args.length == 4:
            return int(port.read_quadlet(args.node, args.offset)).to_bytes(4, "big")
        data: bytes = port.read_block(args.node, args.offset, args.length)
        return data

    try:
        data = _transact(args, "read", action)
    except _Failed as error:
        return _failed(args, error)
    result = {"node": args.node, "offset": args.offset, "length": len(data), "data": data.hex()}
    _report(args, result, quadlets_hex(data))
    return 0


def run_write(args: argparse.Namespace) -> int:
    from fw1394.transport.bus_host import MAX_BLOCK_WRITE

    data = b"".join(_quadlet(value) for value in args.values)
    if len(data) > MAX_BLOCK_WRITE:
        raise CliError(f"{len(data)} bytes of data: a write carries at most {MAX_BLOCK_WRITE}")

    def action(port: Any) -> None:
        if len(data) == 4 and not args.block:
            port.write_quadlet(args.node, args.offset, args.values[0])
        else:
            port.write_block(args.node, args.offset, data)

    try:
        _transact(args, "write", action)
    except _Failed as error:
        return _failed(args, error)
    result = {"node": args.node, "offset": args.offset, "length": len(data), "written": True}
    _report(args, result, f"wrote {len(data)} bytes to node {args.node} at {args.offset:#x}")
    return 0


def run_lock(args: argparse.Namespace) -> int:
    operation: str = args.operation
    wanted = 1 if operation in _NO_ARGUMENT else 2
    if len(args.operands) != wanted:
        shape = "DATA" if wanted == 1 else "ARGUMENT DATA"
        raise CliError(f"{operation} takes {shape} ({wanted} quadlets), not {len(args.operands)}")
    operands = [_quadlet(value) for value in args.operands]
    argument, data = (b"", operands[0]) if wanted == 1 else (operands[0], operands[1])
    if args.node == BROADCAST_PHY:
        raise CliError("locks cannot be broadcast (node 63)")

    def action(port: Any) -> bytes:
        old: bytes = port.lock(args.node, args.offset, LOCK_OPERATIONS[operation], argument, data)
        return old

    try:
        old = _transact(args, "lock", action)
    except _Failed as error:
        return _failed(args, error)
    result = {"node": args.node, "offset": args.offset, "operation": operation, "old": old.hex()}
    _report(args, result, quadlets_hex(old))
    return 0
