"""Where a virtual bus lives: its multicast groups, UDP port and tag, all from its name.

A bus has one group for what every member hears (broadcast, bus management)
and :data:`SHARDS` more for frames addressed to one node: a frame to physical
ID ``p`` travels on shard ``p mod SHARDS``, so the kernel copies it only to the
few members of that shard (and to taps, which join every group) instead of to
all 63.

Several buses run side by side because each name hashes to its own group and
port, and every frame carries a 32-bit tag of the name so that two names that
happen to share a group and port still cannot hear each other (the kernel
filter drops foreign frames before any process wakes up).
"""

from __future__ import annotations

import functools
import hashlib
import re
from dataclasses import dataclass, field

from fw1394.errors import UsageError
from fw1394.packets.nodeid import MAX_NODES

DEFAULT_BUS = "default"
#: Administratively scoped IPv4 multicast (RFC 2365): never routed off a site.
GROUP_PREFIX = (239, 255)
#: Ports below the Linux ephemeral range, so a bus never fights a client socket.
PORT_BASE = 20_000
PORT_SPAN = 10_000
LOOPBACK = "127.0.0.1"
#: Groups for addressed frames. A tap joins all of them and the bus group: 17
#: memberships, inside Linux's default limit of 20 per socket
#: (``net.ipv4.igmp_max_memberships``).
SHARDS = 16
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,62}$")


class BusNameError(UsageError):
    """A bus name that cannot be used (it also names a runtime directory)."""


def check_bus_name(name: str) -> str:
    if not _NAME.match(name):
        raise BusNameError(
            f"bad bus name {name!r}: use 1-63 letters, digits, '.', '_' or '-', "
            "starting with a letter or digit"
        )
    return name


def parse_bus_node(spec: str) -> tuple[str, int]:
    """The bus name and the node's physical ID of a ``bus:NAME/NODE`` target.

    ``spec`` is the text after ``bus:``. The one parser of this target syntax:
    the fuzzer and the bench both read it here, so they accept the same targets
    and refuse the others with the same :class:`BusNameError`.
    """
    name, slash, node = spec.rpartition("/")
    if not slash or not name or not node.isdigit() or not 0 <= int(node) < MAX_NODES:
        raise BusNameError(
            f"'bus:{spec}': a bus target is bus:NAME/NODE, NODE a physical ID 0-{MAX_NODES - 1}"
            " (e.g. bus:default/0)"
        )
    return check_bus_name(name), int(node)


@dataclass(frozen=True, slots=True)
class BusConfig:
    """How a member reaches the bus called ``name``.

    ``interface`` is the local IPv4 address multicast leaves and arrives on:
    loopback by default, the address of a LAN interface to span machines.
    ``ttl`` 0 keeps every datagram on this host; a LAN bus needs 1.
    ``key`` is the bus's secret (``fw1394.transport.sansio.seal``): None looks it up
    (environment, then the bus's runtime directory), ``b""`` means insecure.
    """

    name: str = DEFAULT_BUS
    interface: str = LOOPBACK
    ttl: int = 0
    key: bytes | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        check_bus_name(self.name)
        if not 0 <= self.ttl <= 255:
            raise ValueError(f"multicast TTL {self.ttl} is outside 0..255")

    @property
    def group(self) -> str:
        return _derived(self.name)[0]

    @property
    def shard_groups(self) -> tuple[str, ...]:
        """The groups of addressed frames: physical ID ``p`` listens on ``[p % SHARDS]``."""
        return _derived_shards(self.name)

    @property
    def port(self) -> int:
        return _derived(self.name)[1]

    @property
    def tag(self) -> int:
        """32-bit bus tag carried in every frame."""
        return _derived(self.name)[2]


@functools.cache
def _derived(name: str) -> tuple[str, int, int]:
    """Group, port and tag of bus ``name`` (computed once: every frame needs the tag)."""
    digest = hashlib.sha256(b"fw1394-bus:" + name.encode()).digest()
    # Avoid .0 and .255 in the last octet: some switches treat them specially.
    group = f"{GROUP_PREFIX[0]}.{GROUP_PREFIX[1]}.{digest[0]}.{1 + digest[1] % 254}"
    port = PORT_BASE + int.from_bytes(digest[2:4], "big") % PORT_SPAN
    return group, port, int.from_bytes(digest[4:8], "big")


@functools.cache
def _derived_shards(name: str) -> tuple[str, ...]:
    # The addresses after the bus group's (wrapping inside 1..254), so that one
    # bus's groups are one short run of addresses.
    group = _derived(name)[0]
    prefix, last = group.rsplit(".", 1)
    return tuple(f"{prefix}.{1 + (int(last) + shard) % 254}" for shard in range(SHARDS))
