"""Fault injection on a member's outgoing asynchronous traffic.

The model is the engine's (:mod:`fw1394.engine.faults`), shared with the
in-memory loopback: a bus member injects its loss, duplication and delay into
async packets and acks; bus-management frames are left alone.
"""

from __future__ import annotations

from fw1394.engine.faults import FaultConfig, FaultInjector

__all__ = ["FaultConfig", "FaultInjector"]
