"""``fw1394 send``: one hand-made packet on the bus, and what came back for it.

The packet goes out through the bus's host adapter exactly as given, CRCs
and all, broken or not, addressed to the physical ID in its destination_id
(or ``--to``). The answer is what a 1394 link would see: an ack (or none:
silence) and, for a request, the response packet, both decoded.
"""

from __future__ import annotations

import argparse
import dataclasses
from typing import Any

from fw1394.cli.attach import add_attach_options, open_port
from fw1394.cli.common import CliError, fail, integer, print_json, print_table
from fw1394.node.description import add_bus_options, add_member_options
from fw1394.packets.hextext import hex_bytes

EPILOG = """\
examples:
  fw1394 send ffc00440 ffc3ffff f0000400 98843eb1     a quadlet read as `fw1394 encode` prints it
  fw1394 send ffc00440 ffc3ffff f0000400 00000000     the same with a bad header CRC
  fw1394 send --build read_quadlet_request --set offset=0xfffff0000400 --to 0
  fw1394 send --build lock_request --set extended_tcode=3 --set data=00000001 --to 2 --json

The packet's source_id is sent as given; --build fills in the adapter's.
"""
#: Longest --wait (seconds): the adapter listens no longer than this for an answer.
MAX_WAIT = 10.0


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "send",
        help="put one packet (valid or malformed) on a virtual bus and show the answer",
        description="Put one packet on a virtual 1394 bus as its host adapter and print "
        "what came back: the ack (or silence) and the response, decoded.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("hex", nargs="*", metavar="HEX", help="the packet's bytes, as hex")
    parser.add_argument(
        "--build",
        metavar="KIND",
        help="build the packet from fields instead (a kind of `fw1394 encode`)",
    )
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="FIELD=VALUE",
        help="with --build: a field (number, or hex bytes for data); repeatable",
    )
    parser.add_argument(
        "--to",
        type=integer,
        metavar="PHY",
        help="physical ID to send to (default: from destination_id)",
    )
    parser.add_argument(
        "--wait", type=float, default=0.5, help="seconds to listen for the answer (default 0.5)"
    )
    parser.add_argument("--json", action="store_true", help="one JSON object")
    parser.add_argument("--timeout", type=float, default=1.0, help=argparse.SUPPRESS)
    add_attach_options(parser)
    add_bus_options(parser)
    add_member_options(parser)
    parser.set_defaults(handler=run)


def built_packet(kind: str, settings: list[str], source_id: int, destination: int | None) -> bytes:
    """The wire bytes of a ``kind`` packet with ``settings`` (FIELD=VALUE) applied."""
    from fw1394.packets import ASYNC_CLASSES, encode
    from fw1394.packets.nodeid import node_id

    classes = {_kind_name(cls): cls for cls in ASYNC_CLASSES.values()}
    cls = classes.get(kind)
    if cls is None:
        raise CliError(f"--build {kind!r}: use one of {', '.join(sorted(classes))}")
    fields = {field.name: field for field in dataclasses.fields(cls)}
    values: dict[str, Any] = {}
    if "source_id" in fields:
        values["source_id"] = source_id
    if "destination_id" in fields and destination is not None:
        values["destination_id"] = node_id(destination)
    for setting in settings:
        name, equals, text = setting.partition("=")
        name = name.strip().replace("-", "_")
        if not equals or name not in fields:
            known = ", ".join(n for n in fields if n != "trailing")
            raise CliError(f"--set {setting!r}: use FIELD=VALUE with FIELD one of {known}")
        if fields[name].type == "bytes":
            values[name] = hex_bytes(text)
        else:
            try:
                values[name] = int(text.replace("_", ""), 0)
            except ValueError:
                raise CliError(f"--set {setting!r}: {text!r} is not a number") from None
    try:
        raw: bytes = encode(cls(**values))
    except (TypeError, ValueError) as error:
        raise CliError(f"--build {kind}: {error}") from None
    return raw


def _kind_name(cls: type[Any]) -> str:
    layout = getattr(cls, "LAYOUT", None)
    return str(getattr(layout, "name", None) or cls.NAME)


def decoded(raw: bytes) -> dict[str, Any]:
    """A packet as JSON fields (broken ones with their problems) and a one-line summary."""
    from fw1394.packets import PacketError, decode, field_rows, summary, to_json

    try:
        packet = decode(raw, strict=False, kind="async")
    except PacketError as error:
        return {"hex": raw.hex(), "summary": f"undecodable: {error}", "rows": []}
    rows = field_rows(packet)
    return {"hex": raw.hex(), "summary": summary(packet), "fields": to_json(packet), "rows": rows}


def run(args: argparse.Namespace) -> int:
    from fw1394.host.adapter_port import AdapterPort
    from fw1394.packets import AckCode, name_of
    from fw1394.packets.accessors import DESTINATION_ID
    from fw1394.packets.nodeid import BROADCAST_PHY, node_id, phy_of
    from fw1394.transport.bus_host import StaleGenerationError

    if not 0 < args.wait <= MAX_WAIT:
        raise CliError(f"--wait {args.wait:g}: use more than 0 and at most {MAX_WAIT:g} s")
    if args.to is not None and not 0 <= args.to <= BROADCAST_PHY:
        raise CliError(f"--to {args.to}: a physical ID is 0-63 (63 broadcasts)")
    if bool(args.hex) == bool(args.build):
        raise CliError("give the packet as HEX or --build KIND (one of them)")
    if args.set and not args.build:
        raise CliError("--set goes with --build")
    if getattr(args, "own_member", False):
        raise CliError("send goes through the bus's adapter (no --own-member)")
    with open_port(args) as port:
        if not isinstance(port, AdapterPort):
            raise CliError(f"bus {args.name!r} has no host adapter here: start it with bus up")
        try:
            port.members()  # the adapter's physical ID, for --build's source_id
            me = node_id(port.phy_id if port.phy_id is not None else BROADCAST_PHY)
            if args.build:
                packet = built_packet(args.build, args.set, me, args.to)
            else:
                packet = hex_bytes(" ".join(args.hex))
                if not packet:
                    raise CliError("no hex digits")
            destination = args.to
            if destination is None:
                if len(packet) < 4:
                    raise CliError(f"a {len(packet)}-byte packet names no destination: add --to")
                destination = phy_of(DESTINATION_ID.of_bytes(packet))
            # Pinned to the generation of the member table just read: a packet meant
            # for this physical ID never reaches whoever holds it after a reset.
            reply = port.send_packet(destination, packet, args.wait, generation=port.generation)
        except StaleGenerationError as error:
            return fail(f"send to node {destination}: the bus reset first ({error})", 1)
    sent, response = decoded(packet), decoded(reply.data) if reply.data else None
    result: dict[str, Any] = {
        "to": destination,
        "sent": {key: sent[key] for key in ("hex", "summary", "fields") if key in sent},
        "ack": None if reply.ack < 0 else name_of(AckCode, reply.ack),
        "response": None,
        "generation": reply.generation,
    }
    if response is not None:
        result["response"] = {k: response[k] for k in ("hex", "summary", "fields") if k in response}
    if reply.ack < 0 and response is None:
        crc_ok = sent.get("fields", {}).get("header_crc_ok", True)
        result["silence"] = _silence(port_kind(args, destination), packet, crc_ok)
    if args.json:
        print_json(result)
        return 0
    print(f"sent to node {destination}: {sent['summary']}")
    print(f"ack:      {result['ack'] or 'none (silence)'}")
    if response is None:
        print("response: none" + (f" ({result['silence']})" if "silence" in result else ""))
    else:
        print(f"response: {response['summary']}")
        print_table(response["rows"])
    return 0


def port_kind(args: argparse.Namespace, phy: int) -> str | None:
    """The board kind of node ``phy`` of bus ``--name`` when it runs here."""
    from fw1394.cli.lsnodes import member_labels
    from fw1394.transport.sansio.config import BusConfig
    from fw1394.transport.supervision.observe import watch

    config = BusConfig(args.name, interface=args.interface, ttl=args.ttl)
    view = watch(config, 1.0)
    if view is None or phy >= len(view.members):
        return None
    kind: str | None = member_labels(config, view.generation, view.members)[phy]["kind"]
    return kind


def _silence(kind: str | None, packet: bytes, header_crc_ok: bool) -> str:
    """Why nothing came back, as far as the packet and the node's kind tell."""
    from fw1394.boards.registry import BOARDS
    from fw1394.engine.policy import POLICIES
    from fw1394.host.explain import unserved
    from fw1394.packets.accessors import TCODE

    if len(packet) >= 4:
        why = unserved(kind, TCODE.of_bytes(packet))
        if why:
            return why
    if not header_crc_ok:
        return "its header CRC is wrong: a 1394 node ignores such a packet, not even acking it"
    entry = BOARDS.get(kind or "")
    if entry is not None and POLICIES[entry.policy].bad_crc == "drop":
        return f"a {kind} board silently drops a packet with a bad CRC or length"
    return "nothing answered within --wait"
