"""JHU FPGA1394/QLA boards over Eth1394 (UDP port 1394), as the real host library sees them.

* :mod:`fw1394.boards.qla1.ethernet` models the firmware's Ethernet path for one board
  (sans-IO): which requests are local, which go to FireWire, the extra bytes,
  the generation checks, the unasked broadcast-read response;
* :mod:`fw1394.boards.qla1.rack` puts several boards on an in-process FireWire bus;
* :mod:`fw1394.boards.qla1.eth_server` serves a rack on loopback UDP sockets;
* :mod:`fw1394.boards.qla1.busnode` is one board on the virtual 1394 bus with its
  Ethernet port (the bridge hub, or a board in Ethernet-only mode);
* :mod:`fw1394.jhu.client`, :mod:`fw1394.jhu.scan` and :mod:`fw1394.jhu.rt_loop`
  replay what the host library (Amp1394) sends and checks.

``docs/jhu-eth1394.md`` is the user guide.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Command": "fw1394.jhu.rt_loop",
    "EthUdpClient": "fw1394.jhu.client",
    "RealTimeLoop": "fw1394.jhu.rt_loop",
    "ScanResult": "fw1394.jhu.scan",
    "start_scan": "fw1394.jhu.scan:start",
}

__all__ = [
    "Command",
    "EthUdpClient",
    "RealTimeLoop",
    "ScanResult",
    "start_scan",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.jhu.client import EthUdpClient
    from fw1394.jhu.rt_loop import Command, RealTimeLoop
    from fw1394.jhu.scan import ScanResult
    from fw1394.jhu.scan import start as start_scan
