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
* :mod:`~fw1394.transport.bus_host`, :mod:`~fw1394.transport.bus_port`: the host side.
* :mod:`~fw1394.transport.launch`, :mod:`~fw1394.transport.supervisor`,
  :mod:`~fw1394.transport.runtime`: node processes in the background (each one a
  ``python -m fw1394.node`` process).

``docs/virtual-bus.md`` describes the design, the wire format and the numbers.
"""

from __future__ import annotations

from typing import Any

from fw1394.transport.adapter_protocol import Op
from fw1394.transport.bus_host import BusError, BusHost, StaleGenerationError, TransactionTimeout
from fw1394.transport.bus_port import BusPort
from fw1394.transport.config import BusConfig, BusNameError
from fw1394.transport.eth1394_addresses import Endpoint
from fw1394.transport.launch import AlreadyUpError, LaunchedBus, LaunchError

__all__ = [
    "AlreadyUpError",
    "BusConfig",
    "BusError",
    "BusHost",
    "BusNameError",
    "BusPort",
    "Endpoint",
    "LaunchError",
    "LaunchedBus",
    "Op",
    "StaleGenerationError",
    "TransactionTimeout",
    "open_bus",
]


def open_bus(name: str = "default", **options: Any) -> BusPort:
    """Join bus ``name`` as a host: a :class:`BusPort`, closed by ``with`` or ``close()``.

    ``options`` are :class:`~fw1394.transport.bus_host.BusHost`'s (``ack_timeout``,
    ``split_timeout``, ``join_timeout``, ...). The bus must be running (``fw1394 bus
    up NAME``, or a :class:`LaunchedBus`); reads and writes raise
    :class:`fw1394.TransactionError` (:class:`fw1394.Timeout` when nothing answered).
    """
    return BusPort(BusConfig(name), **options)
