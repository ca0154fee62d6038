"""Host-side robot I/O library, the three layers of the 2010 thesis (7.1).

* top: :class:`RobotIO`, abstract per-axis I/O with latch/apply;
* middle: :class:`Board` (one node, block transfers) and
  :class:`MultiBoard` (several nodes as one robot);
* bottom: a :class:`Port` moving quadlets and blocks; :class:`LocalPort`
  drives in-process board emulators; :class:`BoardPort` addresses boards
  by the board ID they announce, resolved again after every bus reset.

:class:`PositionLoop` is a small PD servo on top of :class:`RobotIO`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "AdapterPort": "fw1394.host.adapter_port",
    "BoardNotOnBusError": "fw1394.host.addressing",
    "BoardPort": "fw1394.host.addressing",
    "Board": "fw1394.host.board",
    "BoardError": "fw1394.host.board",
    "BusPort": "fw1394.host.bus_port",
    "open_bus": "fw1394.host.bus_port",
    "PdGains": "fw1394.host.control",
    "PositionLoop": "fw1394.host.control",
    "Trajectory": "fw1394.host.control",
    "MultiBoard": "fw1394.host.multiboard",
    "LocalPort": "fw1394.host.port",
    "ManualClock": "fw1394.host.port",
    "Port": "fw1394.host.port",
    "UnknownNodeError": "fw1394.host.port",
    "RobotIO": "fw1394.host.robot",
}

__all__ = [
    "AdapterPort",
    "Board",
    "BoardError",
    "BoardNotOnBusError",
    "BoardPort",
    "BusPort",
    "LocalPort",
    "ManualClock",
    "MultiBoard",
    "PdGains",
    "Port",
    "PositionLoop",
    "RobotIO",
    "Trajectory",
    "UnknownNodeError",
    "open_bus",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.host.adapter_port import AdapterPort
    from fw1394.host.addressing import BoardNotOnBusError, BoardPort
    from fw1394.host.board import Board, BoardError
    from fw1394.host.bus_port import BusPort, open_bus
    from fw1394.host.control import PdGains, PositionLoop, Trajectory
    from fw1394.host.multiboard import MultiBoard
    from fw1394.host.port import LocalPort, ManualClock, Port, UnknownNodeError
    from fw1394.host.robot import RobotIO
