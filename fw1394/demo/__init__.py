"""The snake-robot demo: two emulated boards on a virtual bus, servoed at 1 kHz.

:func:`run_demo` brings up a bus with the two nodes of one Snake Robot (seven
axes on the actuation-unit board, four on the Z-Theta/five-bar board), drives
all eleven axes through the host API (:mod:`fw1394.host`) with a PD position
loop, and returns what happened; it stops every process it started.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "DemoResult": "fw1394.demo.run",
    "run_demo": "fw1394.demo.run",
}

__all__ = ["DemoResult", "run_demo"]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.demo.run import DemoResult, run_demo
