"""A drop-in ``libraw1394.so.11`` for programs on the virtual bus.

Programs built against Debian's libraw1394 (``testlibraw``, the JHU host
library's FireWire port, libdc1394...) load this library in its place and
talk to the bus's host adapter (:mod:`fw1394.transport.host_adapter.server`), which
serves them as a PC's kernel serves libraw1394. The C part (``shim.c``,
package data) only marshals calls to the adapter's protocol; :mod:`.build`
compiles it on first use, :mod:`.launch` runs a program with it in place.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "SONAME": "fw1394.raw1394.build",
    "BuildError": "fw1394.raw1394.build",
    "library_path": "fw1394.raw1394.build",
    "environment": "fw1394.raw1394.launch",
}

__all__ = ["SONAME", "BuildError", "environment", "library_path"]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.raw1394.build import SONAME, BuildError, library_path
    from fw1394.raw1394.launch import environment
