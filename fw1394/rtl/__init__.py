"""Link designs in Verilog, simulated with Icarus Verilog through cocotb (``docs/rtl.md``).

A :class:`PortMap` (:func:`load_portmap`) says how a design's ports map onto a
1394 link; :class:`Simulation` runs one and moves packets through it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "PortMap": "fw1394.rtl.portmap",
    "PortMapError": "fw1394.rtl.portmap",
    "Simulation": "fw1394.rtl.simulation",
    "SimulationError": "fw1394.rtl.simulation",
}

__all__ = [
    "PortMap",
    "PortMapError",
    "Simulation",
    "SimulationError",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.rtl.portmap import PortMap, PortMapError
    from fw1394.rtl.simulation import Simulation, SimulationError
