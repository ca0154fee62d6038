"""How host commands reach a bus: through its host adapter, or as a member of their own.

``fw1394 read|write|lock|send|watch`` attach to the bus's adapter (started by
``fw1394 bus up``), which costs the bus nothing: no bus reset, no new node.
``--own-member`` joins the bus as a host of its own instead (a second PC on
the cable: one bus reset to join, one to leave); so does a command on a bus
that has no adapter here (its nodes started by hand), with a note saying so
on a terminal.
"""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from fw1394.cli.common import CliError
from fw1394.node.description import bus_config, faults, timing

if TYPE_CHECKING:
    from fw1394.host.adapter_port import AdapterPort
    from fw1394.host.bus_port import BusPort
    from fw1394.transport.sansio.wire import MemberInfo

__all__ = ["add_attach_options", "host_member", "host_port", "open_port"]

#: Longest wait for one reply from the adapter: its own transaction timeouts (1 s ack,
#: 1 s split, three busy retries) end every transaction before.
ADAPTER_REPLY_TIMEOUT = 10.0


def host_port(args: argparse.Namespace) -> BusPort:
    """A host port on the bus the options name, waiting ``--timeout`` per transaction."""
    from fw1394.host.bus_port import BusPort

    config = bus_config(args)
    try:
        return BusPort(
            config,
            ack_timeout=args.timeout,
            split_timeout=args.timeout,
            timing=timing(args),
            faults=faults(args),
        )
    except OSError as error:  # the socket: say which bus it was for
        raise CliError(f"cannot join bus {config.name!r}: {error}") from None


def add_attach_options(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--own-member",
        action="store_true",
        help="join the bus as a host of its own instead of through its adapter "
        "(a second PC on the cable: a bus reset to join and one to leave)",
    )


def open_port(args: argparse.Namespace) -> AdapterPort | BusPort:
    """The adapter of bus ``--name``, or a host member of its own (see the module)."""
    from fw1394.host.adapter_port import AdapterPort, NoAdapterError

    if getattr(args, "own_member", False):
        return host_port(args)
    try:
        return AdapterPort(args.name, timeout=max(ADAPTER_REPLY_TIMEOUT, args.timeout * 5))
    except NoAdapterError:
        if sys.stderr.isatty():  # for a person; a script's stderr stays its error line
            print(
                f"fw1394: note: bus {args.name!r} has no host adapter here (not started by "
                "`fw1394 bus up`); joining it as a host of its own (two bus resets)",
                file=sys.stderr,
            )
        return host_port(args)


def host_member(port: Any) -> MemberInfo:
    """The bus member that speaks for this program: the adapter, or its own station."""
    from fw1394.host.adapter_port import AdapterPort

    if isinstance(port, AdapterPort):
        members = port.members()
        if port.phy_id is None or port.phy_id >= len(members):
            raise CliError(f"the adapter of bus {port.name!r} is not on the bus")
        return members[port.phy_id]
    info: MemberInfo = port.station.info
    return info
