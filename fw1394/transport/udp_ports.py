"""Who holds a UDP port: refusing a port another server already has, by name.

Servers that bind with SO_REUSEADDR (several sockets on one port, as the JHU
boards' broadcast and multicast sockets must) would otherwise start on a
port another server holds without a word, and the host's unicast then
reaches only one of them. :func:`refuse_taken_port` first tries the address
with a probe socket that does not ask to share: the kernel refuses it
exactly when some socket holds a clashing binding (the same address, or a
wildcard on either side). The holder is then named from ``/proc/net/udp``
(socket inode by local address and port) and the ``/proc/PID/fd`` links
that point at that inode; where those cannot be read (another user's
process, another network namespace) the message says so.
"""

from __future__ import annotations

import errno
import os
import socket
import struct
from dataclasses import dataclass
from pathlib import Path

from fw1394.errors import Error

PROC = Path("/proc")
WILDCARD = "0.0.0.0"
#: Longest command line shown in a message.
COMMAND_SHOWN = 100


class PortInUseError(Error, OSError):
    """A UDP address another socket already holds (one line for the user)."""


@dataclass(frozen=True)
class Holder:
    """A process with a socket on the port."""

    pid: int
    command: str

    def describe(self) -> str:
        return f"pid {self.pid} ({self.command})"


def port_free(host: str, port: int) -> bool:
    """True when nothing holds a binding of ``host:port`` that clashes with one there."""
    probe = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        probe.bind((host, port))
    except OSError as error:
        if error.errno == errno.EADDRINUSE:
            return False
        raise
    finally:
        probe.close()
    return True


def udp_socket_inodes(host: str, port: int, table: Path = PROC / "net" / "udp") -> set[int]:
    """Inodes of the IPv4 UDP sockets bound to ``port`` whose address clashes with ``host``."""
    inodes: set[int] = set()
    try:
        lines = table.read_text().splitlines()[1:]
    except OSError:
        return inodes
    for line in lines:
        fields = line.split()
        if len(fields) < 10:
            continue
        address_hex, _, port_hex = fields[1].partition(":")
        try:
            local = socket.inet_ntoa(struct.pack("=I", int(address_hex, 16)))
            bound_port, inode = int(port_hex, 16), int(fields[9])
        except (ValueError, struct.error):
            continue
        if bound_port != port or not inode:
            continue
        if local == host or WILDCARD in (local, host):
            inodes.add(inode)
    return inodes


def socket_holders(inodes: set[int], proc: Path = PROC) -> list[Holder]:
    """The processes with a file descriptor on one of the sockets ``inodes``."""
    if not inodes:
        return []
    links = {f"socket:[{inode}]" for inode in inodes}
    holders: list[Holder] = []
    for entry in proc.iterdir():
        if not entry.name.isdigit():
            continue
        try:
            descriptors = list((entry / "fd").iterdir())
        except OSError:
            continue  # gone, or not ours to look at
        for descriptor in descriptors:
            try:
                target = os.readlink(descriptor)
            except OSError:
                continue
            if target in links:
                holders.append(Holder(int(entry.name), _command(entry)))
                break
    return holders


def _command(process: Path) -> str:
    try:
        raw = (process / "cmdline").read_bytes()
    except OSError:
        raw = b""
    arguments = raw.decode(errors="replace").split("\0")
    if arguments and arguments[0]:
        arguments[0] = os.path.basename(arguments[0])
    # One line whatever the arguments hold (a ``python -c`` script has newlines).
    command = " ".join(" ".join(arguments).split())
    if not command:
        try:
            command = (process / "comm").read_text().strip()
        except OSError:
            command = "?"
    return command if len(command) <= COMMAND_SHOWN else command[: COMMAND_SHOWN - 3] + "..."


def refuse_taken_port(host: str, port: int, *, share_hint: str | None = None) -> None:
    """PortInUseError naming the holder when ``host:port`` is taken; nothing when free.

    Port 0 (any free port) is never taken.
    """
    if port == 0 or port_free(host, port):
        return
    holders = socket_holders(udp_socket_inodes(host, port))
    if holders:
        who = "by " + ", ".join(holder.describe() for holder in holders)
    else:
        who = "by a process this user cannot see"
    advice = "stop it or choose another port"
    if share_hint:
        advice += f", or pass {share_hint} to share it"
    raise PortInUseError(f"UDP {host}:{port} is in use {who}: {advice}")
