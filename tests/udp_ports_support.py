"""UDP ports for tests that serve on a fixed port (Eth1394 servers bind one port on
several addresses, so port 0 cannot stand in for them).

A port inside the kernel's ephemeral range can be taken at any moment by
another test's client socket (an xdist worker's, say), so the ports handed out
here lie below that range, and are free on every address when chosen.
"""

from __future__ import annotations

import random
import socket
from pathlib import Path

#: The lowest port handed out: above the well-known and common service ports.
LOWEST = 12_000


def _ephemeral_start() -> int:
    try:
        return int(Path("/proc/sys/net/ipv4/ip_local_port_range").read_text().split()[0])
    except (OSError, ValueError, IndexError):
        return 32_768  # Linux's default


def _free(port: int) -> bool:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.bind(("", port))
        except OSError:
            return False
    return True


def quiet_udp_port(span: int = 1) -> int:
    """The first of ``span`` consecutive UDP ports, all free now on every address and
    below the ephemeral range."""
    highest = _ephemeral_start() - span
    for _ in range(200):
        first = random.randrange(LOWEST, highest)
        if all(_free(port) for port in range(first, first + span)):
            return first
    raise RuntimeError(f"no {span} free UDP ports found below {highest + span}")
