"""The virtual 1394 bus: processes on one multicast group behave like nodes on a cable.

* :mod:`~fw1394.transport.config`: a bus name -> multicast group, UDP port, tag.
* :mod:`~fw1394.transport.wire`: the tunnel's frame format.
* :mod:`~fw1394.transport.bpf`, :mod:`~fw1394.transport.medium`: the socket and
  the kernel filter that plays the link layer's address recognition.
* :mod:`~fw1394.transport.membership`: bus resets, self-IDs, physical IDs (sans-IO).
* :mod:`~fw1394.transport.station`: one member's plumbing (node or host).
* :mod:`~fw1394.transport.seal`: the bus key; sealing and verifying frames, replays.
* :mod:`~fw1394.transport.link`: the link layer: frames to engine calls and back,
  for the requester and the responder side of every member and tunnel;
  :mod:`~fw1394.transport.node_express`: a node's common turn in one pass.
* :mod:`~fw1394.transport.bus_host`: the host member (:mod:`fw1394.host.bus_port`
  puts the host library's blocking calls on it).
* :mod:`~fw1394.transport.launch`, :mod:`~fw1394.transport.supervisor`,
  :mod:`~fw1394.transport.runtime`: node processes in the background (each one a
  ``python -m fw1394.node`` process).

``docs/virtual-bus.md`` describes the design, the wire format and the numbers.
"""

from __future__ import annotations

from fw1394.transport.adapter_protocol import Op
from fw1394.transport.bus_host import BusError, BusHost, StaleGenerationError, TransactionTimeout
from fw1394.transport.config import BusConfig, BusNameError
from fw1394.transport.eth1394_addresses import Endpoint
from fw1394.transport.launch import AlreadyUpError, LaunchedBus, LaunchError

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

