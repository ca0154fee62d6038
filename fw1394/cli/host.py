"""``fw1394 read|write|lock``: one transaction on a virtual bus, as its host.

The command runs the transaction through the bus's host adapter (the bus's
PC, shared by every program: no bus reset), or with ``--own-member`` joins
the bus as a host of its own (one bus reset to join, another to leave), as
plugging a second PC into the cable would.

A node is a physical ID (NODE), valid in the bus generation the command
looked it up in: the transaction is pinned to that generation and fails
with ``bus_reset`` rather than reach another node if the bus resets first.
``read`` and ``write`` also take ``--board-id ID`` or ``--guid GUID`` instead
of NODE: the board is looked up in the current generation (and again after a
reset); a GUID is read from each node's configuration ROM.
"""

from __future__ import annotations

import argparse
from typing import Any

from fw1394.cli.attach import add_attach_options, host_member, open_port
from fw1394.cli.common import CliError, fail, integer, print_json
from fw1394.errors import Error
from fw1394.node.description import add_bus_options, add_member_options, bus_config
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
    "read": (
        "examples:\n  fw1394 read 0 0x0\n  fw1394 read 1 0x100 --length 2048 --json\n"
        "  fw1394 read --board-id 1 0x0          (the board whose board ID is 1)\n"
        "  fw1394 read --guid 0x02f139a1b2000101 0xfffff0000410   (GUIDs: fw1394 lsnodes)\n"
    ),
    "write": (
        "examples:\n  fw1394 write 0 0x8 0x12345678\n  fw1394 write 2 0x100 1 2 3 4\n"
        "  fw1394 write --board-id 1 0x8 0x12345678\n"
    ),
    "lock": (
        "examples:\n  fw1394 lock 0 0x10 compare_swap 0x0 0x1   (argument, then data)\n"
        "  fw1394 lock 0 0x10 fetch_add 0x1\n"
    ),
}


def register(subparsers: Any) -> None:
    read = _parser(subparsers, "read", "read a quadlet or a block from a node", by_board=True)
    read.add_argument(
        "--length",
        type=integer,
        default=4,
        help="bytes (4: quadlet read; longer: a block read, at most what one datagram carries)",
    )
    read.set_defaults(handler=run_read)
    write = _parser(subparsers, "write", "write quadlets to a node", by_board=True)
    write.add_argument("values", nargs="+", type=integer, metavar="VALUE", help="quadlets")
    write.add_argument("--block", action="store_true", help="block write even for one quadlet")
    write.set_defaults(handler=run_write)
    lock = _parser(subparsers, "lock", "lock transaction (atomic read-modify-write)")
    lock.add_argument("operation", choices=sorted(LOCK_OPERATIONS), metavar="OPERATION")
    lock.add_argument("operands", nargs="+", type=integer, metavar="QUADLET")
    lock.set_defaults(handler=run_lock)


def _parser(
    subparsers: Any, name: str, text: str, *, by_board: bool = False
) -> argparse.ArgumentParser:
    description = text.capitalize() + " on a virtual 1394 bus, as a host."
    if by_board:
        description += (
            " Address the node by physical ID (NODE, as 1394 does: valid until the next "
            "bus reset), by the board ID it announces (--board-id) or by the GUID in its "
            "configuration ROM (--guid), both looked up again after every reset."
        )
    parser: argparse.ArgumentParser = subparsers.add_parser(
        name,
        help=text + " on a virtual bus",
        description=description,
        epilog=EXAMPLES[name],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    if by_board:
        parser.add_argument(
            "node",
            type=integer,
            nargs="?",
            metavar="NODE",
            help="physical ID (0-62); left out with --board-id or --guid",
        )
        by = parser.add_mutually_exclusive_group()
        by.add_argument(
            "--board-id",
            type=integer,
            metavar="ID",
            help="the node whose board ID (rotary switch, 0-254) is ID, instead of NODE",
        )
        by.add_argument(
            "--guid",
            type=integer,
            metavar="GUID",
            help="the node whose configuration ROM holds GUID (EUI-64, e.g. 0x02f139...), "
            "instead of NODE (fw1394 lsnodes lists them)",
        )
    else:
        parser.add_argument("node", type=integer, metavar="NODE", help="physical ID (0-62)")
        parser.set_defaults(board_id=None, guid=None)
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


def _key(args: argparse.Namespace) -> int | None:
    """The GUID or board ID the node is addressed by; None: by physical ID."""
    guid: int | None = getattr(args, "guid", None)
    return guid if guid is not None else getattr(args, "board_id", None)


def _check(args: argparse.Namespace) -> None:
    board_id = getattr(args, "board_id", None)
    guid = getattr(args, "guid", None)
    if guid is not None and not 0 <= guid < 1 << 64:
        raise CliError(f"--guid {guid:#x} does not fit 64 bits")
    if board_id is not None and not 0 <= board_id <= 254:
        raise CliError(f"--board-id {board_id} is outside 0..254")
    if _key(args) is not None:
        option = "--guid" if guid is not None else "--board-id"
        if args.node is not None:
            # argparse gave the first word to NODE: with --board-id there is none.
            if not hasattr(args, "values"):
                raise CliError(f"with {option} give OFFSET only, no NODE")
            args.offset, args.values = args.node, [args.offset, *args.values]
            args.node = None
    elif args.node is None:
        raise CliError("give NODE (a physical ID), --board-id ID or --guid GUID")
    if not 0 <= args.offset < 1 << 48:
        raise CliError(f"offset {args.offset:#x} does not fit 48 bits")
    if args.node is not None and not 0 <= args.node <= BROADCAST_PHY:
        raise CliError(f"node {args.node} is not a physical ID (0-62, 63 is broadcast)")
    if args.timeout <= 0:
        raise CliError(f"--timeout {args.timeout} must be positive")


def _quadlet(value: int) -> bytes:
    if not 0 <= value < 1 << 32:
        raise CliError(f"{value:#x} does not fit a quadlet (32 bits)")
    return value.to_bytes(4, "big")


def _transact(args: argparse.Namespace, what: str, action: Any) -> Any:
    """Reach the bus, find the node, run ``action(port, node, generation)``, let go.

    The transaction is pinned to the generation the node was found in. By board
    ID, a reset before it went out means looking the board up again; by physical
    ID it is the caller's to decide, so the command fails with ``bus_reset``.
    """
    from fw1394.host.addressing import BoardPort, GuidPort
    from fw1394.transport.bus_host import StaleGenerationError, TransactionError

    config = bus_config(args)
    with open_port(args) as port:
        boards = GuidPort(port) if args.guid is not None else BoardPort(port)
        nodes: dict[int, Any] = {}
        try:
            for attempt in range(_ATTEMPTS):
                key = _key(args)
                if key is None:
                    nodes = dict(port.nodes())
                    _known(args, config, nodes)
                    args.generation = port.generation
                else:
                    args.node, args.generation = boards.locate(key)
                    nodes = dict(enumerate(boards.members))
                try:
                    return action(port, args.node, args.generation)
                except StaleGenerationError:
                    if _key(args) is None or attempt == _ATTEMPTS - 1:
                        raise
        except ValueError as error:  # the bus host's plain ValueError: a block too long
            raise CliError(str(error)) from None
        except TransactionError as error:
            failure = {"reason": str(error.reason)}
            if error.failure.rcode is not None:
                failure["rcode"] = name_of(RCode, error.failure.rcode)
            if error.failure.detail:
                failure["detail"] = error.failure.detail
            message = f"{what} of {_target(args)} at {args.offset:#x}: {error}"
            why = _why_unanswered(args, port, nodes, what, error)
            if why:
                # The board's kind rules the "outcome unknown" out: it never performs these.
                failure["explanation"] = why
                message = f"{what} of {_target(args)} at {args.offset:#x}: {error.reason}: {why}"
            raise _Failed(message, failure) from None
    raise AssertionError("unreachable")


#: Bus resets in a row a transaction by board ID rides out.
_ATTEMPTS = 3


def _known(args: argparse.Namespace, config: Any, nodes: dict[int, Any]) -> None:
    if args.node != BROADCAST_PHY and args.node not in nodes:
        known = ", ".join(str(phy) for phy in sorted(nodes)) or "none"
        raise CliError(
            f"no node {args.node} on bus {config.name!r} (nodes: {known}; "
            "is it up? fw1394 bus up --nodes N)"
        )


def _target(args: argparse.Namespace) -> str:
    if args.guid is not None:
        return f"GUID {args.guid:#018x} (node {args.node})"
    if args.board_id is None:
        return f"node {args.node}"
    return f"board ID {args.board_id} (node {args.node})"


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
        print_json({**_where(args), "offset": args.offset, "error": error.failure})
    return fail(str(error), 1)


def _where(args: argparse.Namespace) -> dict[str, Any]:
    """The node as the command found it: physical ID, board ID if asked by it, generation."""
    where: dict[str, Any] = {"node": args.node}
    if args.board_id is not None:
        where["board_id"] = args.board_id
    if args.guid is not None:
        where["guid"] = f"{args.guid:#018x}"
    where["generation"] = getattr(args, "generation", None)
    return where


def _report(args: argparse.Namespace, result: dict[str, Any], text: str) -> None:
    if args.json:
        print_json(result)
    else:
        print(text)


def run_read(args: argparse.Namespace) -> int:
    from fw1394.transport.bus_host import MAX_BLOCK_READ

    _check(args)
    if not 0 < args.length <= MAX_BLOCK_READ:
        # The 1394 field allows 65535, but the answer must fit one datagram.
        raise CliError(f"--length {args.length} is outside 1..{MAX_BLOCK_READ}")
    if args.node == BROADCAST_PHY:
        raise CliError("reads cannot be broadcast (node 63)")

    def action(port: Any, node: int, generation: int) -> bytes:
        if args.length == 4:
            value = port.read_quadlet(node, args.offset, generation=generation)
            return int(value).to_bytes(4, "big")
        data: bytes = port.read_block(node, args.offset, args.length, generation=generation)
        return data

    try:
        data = _transact(args, "read", action)
    except _Failed as error:
        return _failed(args, error)
    result = {**_where(args), "offset": args.offset, "length": len(data), "data": data.hex()}
    _report(args, result, quadlets_hex(data))
    return 0


def run_write(args: argparse.Namespace) -> int:
    from fw1394.transport.bus_host import MAX_BLOCK_WRITE

    _check(args)
    data = b"".join(_quadlet(value) for value in args.values)
    if len(data) > MAX_BLOCK_WRITE:
        raise CliError(f"{len(data)} bytes of data: a write carries at most {MAX_BLOCK_WRITE}")

    def action(port: Any, node: int, generation: int) -> None:
        if len(data) == 4 and not args.block:
            port.write_quadlet(node, args.offset, args.values[0], generation=generation)
        else:
            port.write_block(node, args.offset, data, generation=generation)

    try:
        _transact(args, "write", action)
    except _Failed as error:
        return _failed(args, error)
    result = {**_where(args), "offset": args.offset, "length": len(data), "written": True}
    _report(args, result, f"wrote {len(data)} bytes to {_target(args)} at {args.offset:#x}")
    return 0


def run_lock(args: argparse.Namespace) -> int:
    _check(args)
    operation: str = args.operation
    wanted = 1 if operation in _NO_ARGUMENT else 2
    if len(args.operands) != wanted:
        shape = "DATA" if wanted == 1 else "ARGUMENT DATA"
        raise CliError(f"{operation} takes {shape} ({wanted} quadlets), not {len(args.operands)}")
    operands = [_quadlet(value) for value in args.operands]
    argument, data = (b"", operands[0]) if wanted == 1 else (operands[0], operands[1])
    if args.node == BROADCAST_PHY:
        raise CliError("locks cannot be broadcast (node 63)")

    def action(port: Any, node: int, generation: int) -> bytes:
        kind = LOCK_OPERATIONS[operation]
        old: bytes = port.lock(node, args.offset, kind, argument, data, generation=generation)
        return old

    try:
        old = _transact(args, "lock", action)
    except _Failed as error:
        return _failed(args, error)
    result = {**_where(args), "offset": args.offset, "operation": operation, "old": old.hex()}
    _report(args, result, quadlets_hex(old))
    return 0
