"""``fw1394 encode`` and ``fw1394 decode``."""

from __future__ import annotations

import argparse
import dataclasses
import sys
from collections.abc import Iterator
from enum import IntEnum
from typing import Any

from fw1394.cli.common import CliError, integer, print_json, print_table
from fw1394.errors import Error
from fw1394.packets import (
    ASYNC_CLASSES,
    PHY_CLASSES,
    Ack,
    AckCode,
    ExtendedTCode,
    Packet,
    PhyPacket,
    PortStatus,
    RCode,
    Retry,
    Speed,
    decode,
    encode,
    field_rows,
    summary,
    to_json,
)
from fw1394.packets.hextext import HexTextError, hex_bytes, quadlets_hex

DECODE_EPILOG = """\
input: one packet as hex arguments, or one packet per line on standard input.
Spaces, newlines, 0x prefixes and upper case are all accepted; a 0x token is one
quadlet (0x1f = 0000001f). Lines starting with # are skipped.

examples:
  fw1394 decode ffc0f140 ffc1ffff f0000984 5bdd119c
  fw1394 decode --no-crc ffc0f140 ffc1ffff f0000984
  fw1394 decode --jhu 0105 ffc01c40 ffd00000 00000004 a9927b79
  fw1394 decode 80458c80 7fba737f          (a self-ID packet and its inverse)
  echo 'ffc0f140 ffc1ffff f0000984 5bdd119c' | fw1394 decode --json

exit status: 0 if every packet decoded, 2 if any input was bad (each bad
packet gets one line on stderr; the others are still printed).
"""

ENCODE_EPILOG = """\
Every field has a default, so only what matters needs to be given; CRCs and the
PHY check quadlet are computed unless given explicitly (to make broken packets).
Output: the wire packet as space-separated 8-digit hex quadlets.

examples:
  fw1394 encode read_quadlet_request --destination-id 0xffc0 --tlabel 5 --offset 0xfffff0000400
  fw1394 encode write_block_request --offset 0x1000 --data '00000011 00000022'
  fw1394 encode self_id --phy-id 1 --link-active --gap-count 63 --scode 2 --port0 2
  fw1394 encode write_response --rcode resp_address_error --tlabel 5
  fw1394 encode ack --code ack_pending --json
Each KIND's --help lists its fields with their widths, meanings and value names.
"""


KIND_EPILOG = """\
CRCs and the PHY check quadlet are computed unless given, so a given wrong
value makes a broken packet on purpose.
"""


def register(subparsers: Any) -> None:
    decoder = subparsers.add_parser(
        "decode",
        help="decode packets given as hex",
        description="Decode IEEE 1394 packets (asynchronous, PHY, ack) given as hex.",
        epilog=DECODE_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    decoder.add_argument("hex", nargs="*", metavar="HEX", help="the packet's quadlets")
    decoder.add_argument("--json", action="store_true", help="one JSON object per packet")
    decoder.add_argument(
        "--no-crc",
        action="store_true",
        help="input has no CRC quadlets (kernel header dumps); CRCs are reported absent",
    )
    decoder.add_argument(
        "--jhu",
        action="store_true",
        help="input is a JHU Eth1394 UDP payload (request with control word, or "
        "response with 8 extra bytes); the framing fields are decoded too",
    )
    decoder.add_argument(
        "--lenient",
        action="store_true",
        help="print broken packets (bad CRC, wrong lengths) with their problems "
        "instead of rejecting them",
    )
    decoder.add_argument(
        "--kind",
        choices=("auto", "async", "phy", "ack"),
        default="auto",
        help="what the bytes are (auto: 1 byte = ack, 8 bytes whose halves are "
        "complements = PHY packet, else asynchronous)",
    )
    decoder.add_argument(
        "-q", "--quiet", action="store_true", help="summary line only, no field table"
    )
    decoder.set_defaults(handler=run_decode)

    encoder = subparsers.add_parser(
        "encode",
        help="build a packet and print it as hex quadlets",
        description="Build an IEEE 1394 packet from fields and print its wire bytes.",
        epilog=ENCODE_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    kinds = encoder.add_subparsers(
        dest="kind", metavar="KIND", required=True, title="kinds (fw1394 encode KIND --help)"
    )
    for cls in (*ASYNC_CLASSES.values(), *PHY_CLASSES, Ack):
        name = _kind_name(cls)
        summary_line = _kind_summary(cls, name)
        kind = kinds.add_parser(
            name,
            help=summary_line,
            description=f"Build a {name} packet: {summary_line}. "
            "Fields not given keep their defaults; numbers may be decimal or 0x hex, "
            "and fields with named values take the name too.",
            epilog=KIND_EPILOG,
        )
        _add_field_options(kind, cls)
        kind.add_argument(
            "--no-crc", action="store_true", help="print without CRC / check quadlets"
        )
        kind.add_argument(
            "--json",
            action="store_true",
            help="print one JSON object (the hex and the decoded fields) instead",
        )
        kind.set_defaults(handler=run_encode, packet_class=cls)


def _kind_name(cls: type[Any]) -> str:
    if cls is Ack:
        return "ack"
    layout = getattr(cls, "LAYOUT", None)
    return str(getattr(layout, "name", None) or cls.NAME)


#: What each field is, for ``encode KIND --help``.
FIELD_MEANINGS = {
    "destination_id": "destination node ID (bus << 6 | PHY ID; 0xffff: broadcast)",
    "source_id": "source node ID (bus << 6 | PHY ID)",
    "tlabel": "transaction label: pairs a response with its request",
    "retry": "retry code",
    "priority": "priority (0 on a cable bus)",
    "offset": "destination offset: the address inside the node",
    "quadlet_data": "the quadlet written or read",
    "data_length": "bytes in the data block (computed from --data when omitted)",
    "extended_tcode": "lock operation",
    "data": "data block, as hex bytes",
    "data_crc": "data block CRC (computed when omitted)",
    "header_crc": "header CRC (computed when omitted)",
    "rcode": "response code",
    "reserved": "reserved bits (0 in a sound packet)",
    "tag": "stream data format tag",
    "channel": "stream channel",
    "sy": "synchronization code",
    "phy_id": "physical ID of the node",
    "inverse": "check quadlet, the complement of the first (computed when omitted)",
    "link_active": "the node's link layer is active",
    "gap_count": "gap count",
    "scode": "speed the PHY can do",
    "phy_delay": "worst-case repeater delay",
    "contender": "contends for isochronous resource manager",
    "power_class": "power consumed or supplied",
    "initiated_reset": "this node started the bus reset",
    "more_packets": "another self-ID packet of this node follows",
    "sequence": "which extended self-ID packet (0..2)",
    "root_id": "PHY ID to become root (with --force-root)",
    "force_root": "R: make root_id the root",
    "gap_count_optimization": "T: set every PHY's gap count",
    "type": "remote access type",
    "page": "register page",
    "port": "port number",
    "register": "PHY register",
    "value": "register value",
    "command": "remote command",
    "fault": "port fault",
    "connected": "port connected",
    "bias": "bias detected",
    "disabled": "port disabled",
    "ok": "command accepted",
    "code": "ack code",
    "parity": "check nibble, the complement of the code (computed when omitted)",
}
for _port in ("port0", "port1", "port2", *(f"port{c}" for c in "abcdefgh")):
    FIELD_MEANINGS[_port] = "port status"
#: Fields whose values have names; either the name or the number is accepted.
FIELD_ENUMS: dict[str, type[IntEnum]] = {
    "retry": Retry,
    "rcode": RCode,
    "extended_tcode": ExtendedTCode,
    "scode": Speed,
    "code": AckCode,
    **{name: PortStatus for name, meaning in FIELD_MEANINGS.items() if meaning == "port status"},
}
#: Short descriptions of kinds whose classes have no docstring of their own.
KIND_SUMMARIES = {
    "write_quadlet_request": "write one quadlet",
    "write_block_request": "write a data block",
    "write_response": "answer a write",
    "read_quadlet_request": "read one quadlet",
    "read_block_request": "read a data block",
    "read_quadlet_response": "answer a quadlet read",
    "read_block_response": "answer a block read",
    "link_on": "Link-on: wake the link layer of a PHY",
    "remote_command": "Remote command: ask another PHY to act on one of its ports",
    "remote_confirmation": "Remote confirmation: a PHY's answer to a remote command",
    "ack": "Acknowledge: a 4-bit ack code followed by its complement",
}


def _kind_summary(cls: type[Any], name: str) -> str:
    doc = (cls.__doc__ or "").strip()
    # A dataclass without a docstring gets its signature as one: not for people.
    text = doc.splitlines()[0] if doc and not doc.startswith(cls.__name__ + "(") else ""
    text = KIND_SUMMARIES.get(name, text.replace("``", "")) or name
    layout = getattr(cls, "LAYOUT", None)
    tcode = getattr(layout, "tcode", None)
    return f"{text} (tcode {int(tcode):#x})" if tcode is not None else text


def _field_widths(cls: type[Any]) -> dict[str, int]:
    if cls is Ack:
        return {"code": 4, "parity": 4}
    layout = cls.LAYOUT
    if issubclass(cls, PhyPacket):
        return {**layout.widths, "inverse": 32}
    return {**layout.sealed_header.widths, "data_crc": 32}


def field_value(name: str, width: int | None, enum: type[IntEnum] | None) -> Any:
    """argparse type for a field: a number (or a value name) that fits in its bits."""

    def parse(text: str) -> int:
        if enum is not None and text in enum.__members__:
            return int(enum[text])
        try:
            value = integer(text)
        except argparse.ArgumentTypeError:
            if enum is None:
                raise
            names = ", ".join(enum.__members__)
            raise argparse.ArgumentTypeError(
                f"{text!r} is neither a number nor a {name} name ({names})"
            ) from None
        if width is not None and not 0 <= value < 1 << width:
            raise argparse.ArgumentTypeError(
                f"{value} ({value:#x}) does not fit in {width} bits (0..{(1 << width) - 1:#x})"
            )
        return value

    parse.__name__ = name  # argparse names the type in some messages
    return parse


def _field_help(name: str, width: int | None, enum: type[IntEnum] | None, default: Any) -> str:
    meaning = FIELD_MEANINGS.get(name, name.replace("_", " "))
    size = f"{width} bits: " if width else ""
    text = size + meaning
    if enum is not None:
        text += "; " + ", ".join(f"{int(m)} {m.name}" for m in enum)
    if default is not None and default is not dataclasses.MISSING and "omitted" not in meaning:
        shown = f"{default:#x}" if isinstance(default, int) and default > 255 else default
        if isinstance(default, IntEnum):
            shown = default.name
        elif isinstance(default, bytes):
            shown = default.hex() or "empty"
        text += f" (default {shown})"
    return text


def _add_field_options(parser: argparse.ArgumentParser, cls: type[Any]) -> None:
    layout_names: tuple[str, ...] = getattr(getattr(cls, "LAYOUT", None), "names", ())
    widths = _field_widths(cls)
    for field in dataclasses.fields(cls):
        if field.name == "trailing":
            continue
        if issubclass(cls, PhyPacket) and field.name not in (*layout_names, "inverse"):
            continue  # e.g. phy_id, which a PHY configuration packet does not carry
        option = "--" + field.name.replace("_", "-")
        default = field.default
        enum = FIELD_ENUMS.get(field.name)
        width = widths.get(field.name)
        if field.type == "bool":
            parser.add_argument(
                option,
                action=argparse.BooleanOptionalAction,
                default=default,
                help=FIELD_MEANINGS.get(field.name, field.name),
            )
        elif field.type == "bytes":
            parser.add_argument(
                option,
                type=hex_bytes_argument,
                default=default,
                metavar="HEX",
                help=_field_help(field.name, None, None, default),
            )
        else:
            parser.add_argument(
                option,
                type=field_value(field.name, width, enum),
                default=default,
                metavar="NAME|N" if enum is not None else "N",
                help=_field_help(field.name, width, enum, default),
            )


def hex_bytes_argument(text: str) -> bytes:
    try:
        return hex_bytes(text)
    except HexTextError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


def run_encode(args: argparse.Namespace) -> int:
    cls: type[Any] = args.packet_class
    values = {
        field.name: getattr(args, field.name)
        for field in dataclasses.fields(cls)
        if hasattr(args, field.name)
    }
    try:
        packet: Packet = cls(**values)
    except TypeError as error:
        raise CliError(str(error)) from None
    raw = encode(packet, crc=not args.no_crc)
    text = raw.hex() if isinstance(packet, Ack) else quadlets_hex(raw)
    if args.json:
        decoded = decode(raw, crc=not args.no_crc, strict=False, kind=_kind(packet))
        print_json({"hex": text, **to_json(decoded)})
    else:
        print(text)
    return 0


def _kind(packet: Packet) -> Any:
    return "ack" if isinstance(packet, Ack) else "phy" if isinstance(packet, PhyPacket) else "async"


def _inputs(args: argparse.Namespace) -> Iterator[tuple[str, str]]:
    if args.hex:
        yield "arguments", " ".join(args.hex)
        return
    if sys.stdin.isatty():
        raise CliError("no packet given: pass hex arguments or pipe packets, one per line")
    for number, line in enumerate(sys.stdin, 1):
        text = line.split("#", 1)[0].strip()
        if text:
            yield f"line {number}", text


def run_decode(args: argparse.Namespace) -> int:
    status = 0
    given = 0
    for where, text in _inputs(args):
        given += 1
        try:
            raw = hex_bytes(text)
            if not raw:
                raise CliError("no hex digits")
            if args.jhu:
                _print_jhu(raw, args)
            else:
                _print_packet(
                    decode(raw, crc=not args.no_crc, strict=not args.lenient, kind=args.kind), args
                )
        except Error as error:  # this line's packet: report it, go on with the next
            print(f"fw1394: error: {where}: {error}", file=sys.stderr)
            status = 2
    if not given:
        what = "Eth1394 payload" if args.jhu else "packet"
        raise CliError(
            f"no {what} on standard input: it was empty or held only blank and # comment lines "
            "(one packet per line, as hex)"
        )
    return status


def _print_packet(
    packet: Packet, args: argparse.Namespace, extra: dict[str, Any] | None = None
) -> None:
    if args.json:
        print_json({**(extra or {}), **to_json(packet)})
        return
    print(summary(packet))
    if not args.quiet:
        print_table(field_rows(packet))


def _split_eth1394(payload: bytes) -> tuple[dict[str, Any], bytes]:
    """Framing fields and the 1394 packet of an Eth1394 UDP payload.

    Requests carry a 2-byte control word before quadlets, responses 8 extra bytes
    after them, so the payload length modulo 4 tells the direction.
    """
    from fw1394.packets import eth1394

    if len(payload) % 4 == 2:
        request = eth1394.parse_request(payload)
        framing = {"direction": "request", **dataclasses.asdict(request.control)}
        return framing, request.packet
    response = eth1394.parse_response(payload)
    return {"direction": "response", **dataclasses.asdict(response.extra)}, response.packet


def _print_jhu(raw: bytes, args: argparse.Namespace) -> None:
    framing, packet_bytes = _split_eth1394(raw)
    if not packet_bytes and framing["direction"] == "request":
        raise CliError("Eth1394 request has a control word but no 1394 packet")
    if not packet_bytes:
        # The FPGA's 8-byte "read dropped" notice: framing only.
        if args.json:
            print_json({"eth1394": framing})
        else:
            print(_framing_line(framing))
        return
    # The FPGA's Ethernet path sends zero CRCs and the host never checks them, so
    # responses are decoded leniently: their CRC state is shown, not enforced.
    lenient = args.lenient or framing["direction"] == "response"
    packet = decode(packet_bytes, strict=not lenient, kind="async")
    if args.json:
        _print_packet(packet, args, {"eth1394": framing})
        return
    print(_framing_line(framing))
    _print_packet(packet, args)


def _framing_line(framing: dict[str, Any]) -> str:
    return "eth1394 " + " ".join(f"{key}={value}" for key, value in framing.items())
