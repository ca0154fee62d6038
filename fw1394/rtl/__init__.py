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
    "HDL_DIR": "fw1394.rtl.portmap",
    "load_portmap": "fw1394.rtl.portmap:load",
    # The PHY model as a cocotb driver and monitor (imports cocotb).
    "PhyDriver": "fw1394.rtl.testbench",
    "PhyMonitor": "fw1394.rtl.testbench",
    "harness_sources": "fw1394.rtl.testbench",
}

__all__ = [
    "HDL_DIR",
    "PhyDriver",
    "PhyMonitor",
    "PortMap",
    "PortMapError",
    "Simulation",
    "SimulationError",
    "harness_sources",
    "load_portmap",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.rtl.portmap import HDL_DIR, PortMap, PortMapError
    from fw1394.rtl.portmap import load as load_portmap
    from fw1394.rtl.simulation import Simulation, SimulationError
    from fw1394.rtl.testbench import PhyDriver, PhyMonitor, harness_sources
