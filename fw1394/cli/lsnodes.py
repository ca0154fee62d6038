"""``fw1394 lsnodes``: the nodes of a bus, what they are and what their ROMs say.

In the spirit of ``lsfirewire``: per node its physical and node ID, role,
board kind, board ID and, read from its configuration ROM (CSR offset 0x400)
through the bus's adapter, its GUID (EUI-64), vendor and model. A board
without a ROM (the thesis board reads 0 there, plain memory has no CSR
space) is listed as having none.

With ``--json`` the GUID is a string of 16 hex digits after ``0x``
(``"0x00fa610e00000003"``), as tools print EUI-64s: a JSON number above 2**53
loses digits in most readers, JavaScript's and jq's among them.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from typing import Any

from fw1394.cli.attach import add_attach_options, host_member, open_port
from fw1394.cli.common import CliError, print_json, print_table
from fw1394.node.description import add_bus_options, add_member_options

EPILOG = """\
examples:
  fw1394 lsnodes                       every node of bus "default"
  fw1394 lsnodes --name arm --json     one JSON object per node

In --json, "guid" is a string of 16 hex digits after 0x ("0x00fa610e00000003"):
a 64-bit number does not survive JSON readers that use doubles; "rom" is false
(and "guid" absent) for a node without a configuration ROM.
"""
#: Quadlets of one ROM read at most (1 KiB of ROM space).
_ROM_QUADLETS = 256
NO_ROM = "no configuration ROM"


def register(subparsers: Any) -> None:
    parser = subparsers.add_parser(
        "lsnodes",
        help="list the nodes of a virtual bus: kind, IDs, GUID, vendor, model",
        description="List the nodes of a virtual 1394 bus with what their configuration "
        "ROMs say (read through the bus's host adapter).",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--json",
        action="store_true",
        help='one JSON object per node ("guid": "0x" and 16 hex digits)',
    )
    parser.add_argument(
        "--timeout", type=float, default=0.5, help="ack and response timeout (s) of --own-member"
    )
    add_attach_options(parser)
    add_bus_options(parser)
    add_member_options(parser)
    parser.set_defaults(handler=run)


def member_kinds(bus: str, me: Any, members: Sequence[Any]) -> list[str | None]:
    """Board kind of each member as seen from member ``me`` (None: unknown or a host)."""
    from fw1394.watch.detect import member_kind

    return [None if m.host else member_kind(bus, me, m) for m in members]


def read_rom(port: Any, node: int, generation: int) -> dict[int, int] | None:
    """The quadlets of ``node``'s configuration ROM by CSR offset; None if it has none.

    Every read is pinned to ``generation``, the one ``node`` was listed in."""
    from fw1394.capture.analysis.csr import CONFIG_ROM, CSR_BASE
    from fw1394.capture.analysis.rom_decode import decode_rom
    from fw1394.transport.bus_host import TransactionError

    quadlets: dict[int, int] = {}
    try:
        quadlets[CONFIG_ROM] = port.read_quadlet(node, CSR_BASE + CONFIG_ROM, generation=generation)
        if quadlets[CONFIG_ROM] == 0:
            return None  # a ROM header of 0 describes no bus information block
        for _ in range(_ROM_QUADLETS):
            wanted = sorted(set(decode_rom(quadlets).missing) - quadlets.keys())
            if not wanted:
                break
            for address in wanted:
                quadlets[address] = port.read_quadlet(
                    node, CSR_BASE + address, generation=generation
                )
    except TransactionError:
        return quadlets if len(quadlets) > 1 else None
    return quadlets


def guid_text(eui64: int) -> str:
    """A GUID as JSON carries it: ``0x`` and 16 hex digits, leading zeros kept."""
    return f"0x{eui64:016x}"


def describe_rom(quadlets: dict[int, int] | None) -> dict[str, Any]:
    """GUID, vendor and model of a ROM (the text leaves after Vendor and Model)."""
    from fw1394.capture.analysis.rom_decode import decode_rom

    if quadlets is None:
        return {"rom": False}
    report = decode_rom(quadlets)
    guid = None if report.eui64 is None else guid_text(report.eui64)
    found: dict[str, Any] = {"rom": True, "guid": guid}
    texts = {block.address: block.text for block in report.blocks if block.text is not None}
    root = next((b for b in report.blocks if b.kind == "root_directory"), None)
    previous = None
    for item in root.entries if root else []:
        if item["key"] in ("Vendor", "Model") and item["key_type"] == "immediate":
            found[f"{item['key'].lower()}_id"] = item["value"]
            previous = item["key"].lower()
        elif item["key"] == "Descriptor" and previous and item.get("target") in texts:
            found[previous] = texts[item["target"]]
            previous = None
    return found


def run(args: argparse.Namespace) -> int:
    from fw1394.packets.nodeid import node_id

    with open_port(args) as port:
        me = host_member(port)
        nodes = port.nodes()
        generation = port.generation
        if not nodes:
            raise CliError(f"bus {args.name!r} has no nodes (fw1394 bus up --nodes N)")
        kinds = member_kinds(args.name, me, [m for _, m in nodes])
        rows = []
        for (phy, member), kind in zip(nodes, kinds, strict=True):
            row: dict[str, Any] = {
                "phy_id": phy,
                "node_id": node_id(phy),
                "generation": generation,
                "role": "host" if member.host else "node",
                "kind": kind,
                "board_id": None if member.board_id == 0xFF else member.board_id,
                "pid": member.pid,
            }
            row.update(describe_rom(read_rom(port, phy, generation)))
            rows.append(row)
    if args.json:
        print_json(*rows)
        return 0
    table = [("PHY", "NODE", "GEN", "KIND", "BOARD", "GUID", "VENDOR", "MODEL")]
    for row in rows:
        guid = row["guid"][2:] if row.get("guid") is not None else "-"
        if not row["rom"]:
            guid, vendor, model = NO_ROM, "", ""
        else:
            vendor = _named(row, "vendor")
            model = _named(row, "model")
        board = "-" if row["board_id"] is None else str(row["board_id"])
        table.append(
            (
                str(row["phy_id"]),
                f"{row['node_id']:#06x}",
                str(row["generation"]),
                row["kind"] or "unknown",
                board,
                guid,
                vendor,
                model,
            )
        )
    print_table(table, indent="")
    return 0


def _named(row: dict[str, Any], key: str) -> str:
    number = row.get(f"{key}_id")
    text = row.get(key)
    if number is None:
        return text or "-"
    return f"{number:#08x} {text}" if text else f"{number:#08x}"


def member_labels(config: Any, generation: int, members: Sequence[Any]) -> list[dict[str, Any]]:
    """For ``bus status``: each member's board kind, generation and role (the adapter named)."""
    from fw1394.transport.host_adapter.server import adapter_pid
    from fw1394.transport.sansio.wire import MemberInfo
    from fw1394.transport.supervision.procs import pid_namespace
    from fw1394.transport.supervision.runtime import bus_dir

    here = MemberInfo(0, 0, address=config.interface, pid_namespace=pid_namespace())
    adapter = adapter_pid(bus_dir(config.name))
    labels = []
    for member, kind in zip(members, member_kinds(config.name, here, members), strict=True):
        local = member.address == here.address and member.pid_namespace == here.pid_namespace
        label: dict[str, Any] = {"kind": kind, "generation": generation}
        if member.host and local and member.pid == adapter:
            label["role"] = "adapter"
        labels.append(label)
    return labels
