"""``fw1394 encode`` and ``fw1394 decode``."""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
from collections.abc import Iterator
from typing import Any

from fw1394.cli.common import CliError, hex_bytes, integer, print_table
from fw1394.packets import (
    ASYNC_CLASSES,
    PHY_CLASSES,
    Ack,
    AckCode,
    Packet,
    PacketError,
    PhyPacket,
    decode,
    encode,
    field_rows,
    summary,
    to_json,
)
from fw1394.packets.hextext import quadlets_hex

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
  fw1394 encode ack --code 2
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
    kinds = encoder.add_subparsers(dest="kind", metavar="KIND", required=True)
    for cls in (*ASYNC_CLASSES.values(), *PHY_CLASSES, Ack):
        name = _kind_name(cls)
        kind = kinds.add_parser(
            name,
            help=(cls.__doc__ or name).strip().splitlines()[0],
            description=f"Build a {name} packet. Fields not given keep their defaults.",
            formatter_class=argparse.ArgumentDefaultsHelpFormatter,
        )
        _add_field_options(kind, cls)
        kind.add_argument(
            "--no-crc", action="store_true", help="print without CRC / check quadlets"
        )
        kind.add_argument("--json", action="store_true", help="also print the decoded fields")
        kind.set_defaults(handler=run_encode, packet_class=cls)


def _kind_name(cls: type[Any]) -> str:
    if cls is Ack:
        return "ack"
    layout = getattr(cls, "LAYOUT", None)
    return str(getattr(layout, "name", None) or cls.NAME)


def _add_field_options(parser: argparse.ArgumentParser, cls: type[Any]) -> None:
    layout_names: tuple[str, ...] = getattr(getattr(cls, "LAYOUT", None), "names", ())
    for field in dataclasses.fields(cls):
        if field.name == "trailing":
            continue
        if issubclass(cls, PhyPacket) and field.name not in (*layout_names, "inverse"):
            continue  # e.g. phy_id, which a PHY configuration packet does not carry
        option = "--" + field.name.replace("_", "-")
        default = field.default
        if field.type == "bool":
            parser.add_argument(
                option, action=argparse.BooleanOptionalAction, default=default, help=field.name
            )
        elif field.type == "bytes":
            parser.add_argument(
                option, type=hex_bytes_argument, default=default, metavar="HEX", help="hex bytes"
            )
        else:
            computed = default is None or (field.name == "data_length" and default == -1)
            parser.add_argument(
                option,
                type=integer,
                default=default,
                metavar="N",
                help="computed when omitted" if computed else _field_help(field.name),
            )


def _field_help(name: str) -> str:
    return {
        "destination_id": "16-bit destination (bus << 6 | node)",
        "source_id": "16-bit source (bus << 6 | node)",
        "tlabel": "transaction label 0..63",
        "retry": "0 retry_1, 1 retry_X, 2 retry_A, 3 retry_B",
        "rcode": "0 complete, 4 conflict, 5 data, 6 type, 7 address error",
        "offset": "48-bit destination offset",
        "extended_tcode": "1 mask_swap, 2 compare_swap, 3 fetch_add, 4 little_add, "
        "5 bounded_add, 6 wrap_add, 7 vendor_dependent",
        "code": "ack code: " + ", ".join(f"{c.value} {c.name}" for c in AckCode),
    }.get(name, name)


def hex_bytes_argument(text: str) -> bytes:
    try:
        return hex_bytes(text)
    except CliError as error:
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
    print(raw.hex() if isinstance(packet, Ack) else quadlets_hex(raw))
    if args.json:
        print(
            json.dumps(to_json(decode(raw, crc=not args.no_crc, strict=False, kind=_kind(packet))))
        )
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
    for where, text in _inputs(args):
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
        except (CliError, PacketError) as error:
            print(f"fw1394: error: {where}: {error}", file=sys.stderr)
            status = 2
    return status


def _print_packet(
    packet: Packet, args: argparse.Namespace, extra: dict[str, Any] | None = None
) -> None:
    if args.json:
        print(json.dumps({**(extra or {}), **to_json(packet)}))
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

    try:
        if len(payload) % 4 == 2:
            request = eth1394.parse_request(payload)
            framing = {"direction": "request", **dataclasses.asdict(request.control)}
            return framing, request.packet
        response = eth1394.parse_response(payload)
    except eth1394.Eth1394Error as error:
        raise CliError(f"Eth1394 framing: {error}") from None
    return {"direction": "response", **dataclasses.asdict(response.extra)}, response.packet


def _print_jhu(raw: bytes, args: argparse.Namespace) -> None:
    framing, packet_bytes = _split_eth1394(raw)
    if not packet_bytes and framing["direction"] == "request":
        raise CliError("Eth1394 request has a control word but no 1394 packet")
    if not packet_bytes:
        # The FPGA's 8-byte "read dropped" notice: framing only.
        print(json.dumps({"eth1394": framing}) if args.json else _framing_line(framing))
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
