"""A drop-in ``libraw1394.so.11`` for programs on the virtual bus.

Programs built against Debian's libraw1394 (``testlibraw``, the JHU host
library's FireWire port, libdc1394...) load this library in its place and
talk to the bus's host adapter (:mod:`fw1394.transport.host_adapter.server`), which
serves them as a PC's kernel serves libraw1394. The C part (``shim.c``,
package data) only marshals calls to the adapter's protocol; :mod:`.build`
compiles it on first use, :mod:`.launch` runs a program with it in place.
"""

from fw1394.raw1394.build import SONAME, BuildError, library_path
from fw1394.raw1394.launch import environment

__all__ = ["SONAME", "BuildError", "environment", "library_path"]
