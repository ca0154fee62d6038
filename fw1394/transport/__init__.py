"""The virtual 1394 bus: processes on one host (or several) behave like nodes on a cable.

By role:

* :mod:`~fw1394.transport.sansio`: the bus's rules without I/O: names and groups,
  the frame format, membership (bus resets, self-IDs, physical IDs), the seal.
* :mod:`~fw1394.transport.media`: what carries the frames (UDP multicast, a
  shared-memory ring), the kernel filter, and how a member waits (idle strategies).
* :mod:`~fw1394.transport.supervision`: node processes in the background (each one
  a ``python -m fw1394.node`` process), runtime directories, the bus key,
  looking at a bus from outside, and the one ``stop`` for every child process.
* :mod:`~fw1394.transport.host_adapter`: the one host member a machine's programs share.

A member's own pieces sit at the top: :mod:`~fw1394.transport.station` (one member's
plumbing, node or host), :mod:`~fw1394.transport.link` (frames to engine calls and
back, both roles), :mod:`~fw1394.transport.node_express` (a node's common turn in one
pass), :mod:`~fw1394.transport.bus_host` (the host member; :mod:`fw1394.host.bus_port`
puts the host library's blocking calls on it), :mod:`~fw1394.transport.copies`
(second copies of an answer; fault injection is the engine's
:mod:`~fw1394.engine.faults`), and
the Eth1394 world's addresses and UDP port checks (:mod:`~fw1394.transport.eth1394_addresses`,
:mod:`~fw1394.transport.udp_ports`).

``docs/virtual-bus.md`` describes the design, the wire format and the numbers.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "BusError": "fw1394.transport.bus_host",
    "BusHost": "fw1394.transport.bus_host",
    "StaleGenerationError": "fw1394.transport.bus_host",
    "TransactionTimeout": "fw1394.transport.bus_host",
    "Endpoint": "fw1394.transport.eth1394_addresses",
    "Op": "fw1394.transport.host_adapter.protocol",
    "BusConfig": "fw1394.transport.sansio.config",
    "BusNameError": "fw1394.transport.sansio.config",
    "AlreadyUpError": "fw1394.transport.supervision.launch",
    "LaunchedBus": "fw1394.transport.supervision.launch",
    "LaunchError": "fw1394.transport.supervision.launch",
}

__all__ = [
    "AlreadyUpError",
    "BusConfig",
    "BusError",
    "BusHost",
    "BusNameError",
    "Endpoint",
    "LaunchError",
    "LaunchedBus",
    "Op",
    "StaleGenerationError",
    "TransactionTimeout",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.transport.bus_host import (
        BusError,
        BusHost,
        StaleGenerationError,
        TransactionTimeout,
    )
    from fw1394.transport.eth1394_addresses import Endpoint
    from fw1394.transport.host_adapter.protocol import Op
    from fw1394.transport.sansio.config import BusConfig, BusNameError
    from fw1394.transport.supervision.launch import AlreadyUpError, LaunchedBus, LaunchError
