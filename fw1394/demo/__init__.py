"""The snake-robot demo: two emulated boards on a virtual bus, servoed at 1 kHz.

:func:`run_demo` brings up a bus with the two nodes of one Snake Robot (seven
axes on the actuation-unit board, four on the Z-Theta/five-bar board), drives
all eleven axes through the host API (:mod:`fw1394.host`) with a PD position
loop, and returns what happened; it stops every process it started.
"""

from fw1394.demo.run import DemoResult, run_demo

__all__ = ["DemoResult", "run_demo"]
