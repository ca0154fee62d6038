"""Addresses of the Eth1394 world, and the loopback-only rule that guards them.

The host library derives every address from the one server IP it is given:
per-board unicast addresses (firmware >= 9) add the board number to the last
octet, broadcasts go to the classful broadcast address, and Ethernet-only
mode multicasts to 224.0.0.100. fw1394 serves and sends only on loopback
(127.0.0.0/8): :func:`require_loopback` refuses anything else, and
:func:`multicast_route_check` tells whether a real host's multicast would
stay on this machine.
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from ipaddress import IPv4Address, IPv4Network
from pathlib import Path

from fw1394.errors import UsageError
from fw1394.packets.eth1394 import MULTICAST_GROUP, UDP_PORT

LOOPBACK_NETWORK = IPv4Network("127.0.0.0/8")
DEFAULT_LOOPBACK_SERVER = "127.0.0.1"
#: The firmware revision from which each board has its own address and the
#: host switches to multicast (and, on an FPGA V3, to Ethernet-only mode).
MULTICAST_FIRMWARE = 9


class AddressRefusedError(UsageError):
    """An address fw1394 will not use: it would reach beyond this machine."""


@dataclass(frozen=True)
class Endpoint:
    """A server address and UDP port (the real host always uses port 1394)."""

    host: str = DEFAULT_LOOPBACK_SERVER
    port: int = UDP_PORT

    def __str__(self) -> str:
        return f"{self.host}:{self.port}"


def parse_endpoint(text: str | None) -> Endpoint:
    """``ADDRESS[:PORT]`` (either part may be empty) as an :class:`Endpoint`."""
    if not text:
        return Endpoint()
    host, _, port = text.partition(":")
    try:
        endpoint = Endpoint(host or DEFAULT_LOOPBACK_SERVER, int(port) if port else UDP_PORT)
        IPv4Address(endpoint.host)
    except ValueError:
        raise AddressRefusedError(f"{text!r} is not IPV4ADDRESS[:PORT]") from None
    if not 0 < endpoint.port < 65536:
        raise AddressRefusedError(f"port {endpoint.port} is outside 1..65535")
    return endpoint


def require_loopback(address: str) -> str:
    """``address`` if it is in 127.0.0.0/8, else :class:`AddressRefusedError`."""
    if IPv4Address(address) not in LOOPBACK_NETWORK:
        raise AddressRefusedError(
            f"{address} is not a loopback address: fw1394 only serves and sends on 127.0.0.0/8"
        )
    return address


@functools.lru_cache(maxsize=256)  # a host asks for the same few addresses all the time
def offset_address(base: str, offset: int) -> str:
    """``base`` with ``offset`` added to its last octet, as host and firmware >= 9 do."""
    packed = bytearray(IPv4Address(base).packed)
    packed[3] = (packed[3] + offset) & 0xFF
    return str(IPv4Address(bytes(packed)))


def board_address(base: str, board_id: int, firmware: int) -> str:
    """Where the host sends a board's unicast requests (the base IP before firmware 9)."""
    return offset_address(base, board_id) if firmware >= MULTICAST_FIRMWARE else base


@functools.lru_cache(maxsize=64)
def classful_broadcast(address: str) -> str:
    """The host's broadcast address: the classful network of ``address``, all ones."""
    octets = IPv4Address(address).packed
    kept = 1 if octets[0] < 128 else 2 if octets[0] < 192 else 3 if octets[0] < 224 else 0
    return str(IPv4Address(octets[:kept] + b"\xff" * (4 - kept)))


# -- where would a real host's multicast go? ------------------------------------------------

PROC_ROUTE = Path("/proc/net/route")


def _route_rows(table: str) -> list[tuple[str, int, int]]:
    rows = []
    for line in table.splitlines()[1:]:
        fields = line.split()
        if len(fields) < 8:
            continue
        # Destination and mask are little-endian hex in /proc/net/route.
        destination = int.from_bytes(bytes.fromhex(fields[1]), "little")
        mask = int.from_bytes(bytes.fromhex(fields[7]), "little")
        rows.append((fields[0], destination, mask))
    return rows


def multicast_interface(group: str = MULTICAST_GROUP, table: str | None = None) -> str | None:
    """Interface of the main-table route a host's datagram to ``group`` would take.

    None when no route covers the group (the host's send then fails with
    "Network is unreachable": nothing leaves the machine either).
    """
    if table is None:
        try:
            table = PROC_ROUTE.read_text()
        except OSError:
            return None
    target = int(IPv4Address(group))
    best: tuple[int, str] | None = None
    for interface, destination, mask in _route_rows(table):
        if target & mask == destination and (best is None or mask > best[0]):
            best = (mask, interface)
    return None if best is None else best[1]


def multicast_route_check(table: str | None = None) -> str | None:
    """None if a real host's multicast to 224.0.0.100 stays on loopback, else why not."""
    interface = multicast_interface(MULTICAST_GROUP, table)
    if interface is None or interface == "lo":
        return None
    return (
        f"a host's multicast to {MULTICAST_GROUP} would leave through {interface}; "
        "serve firmware >= 9 only in a network namespace whose multicast route is on lo "
        "(ip netns add NAME; ip -n NAME link set lo up; "
        "ip -n NAME route add 224.0.0.0/4 dev lo), or use firmware 8 (bridge mode)"
    )
