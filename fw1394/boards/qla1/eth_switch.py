"""The FPGA V3 Ethernet switch's status block at 0x40A0 (firmware 9 on), as ``ethswitch`` reads it.

32 quadlets (FpgaIO's ReadEthernetData at offset 0xA0; the layout is the
switch's debug data, which ``ethswitch`` overlays with a little-endian C
struct after swapping each quadlet to host order, so the fields are packed
from the low end of each quadlet):

| Quadlet | Content |
|---|---|
| 0 | "ESW0" (the bytes E, S, W, 0 from bit 0 up) |
| 1 | port attributes (ports Eth1, Eth2, PS, RT): bits 3..0 active, 7..4 fast, |
| | 11..8 receive ready, 15..12 data ready |
| 2-3, 4-5 | packets received, sent: 16 bits per port |
| 6, 7, 8, 9 | transmit info, CRC errors in, CRC errors out, IPv4 errors in: 8 bits per port |
| 12-15 | FIFO active/underflow, empty/full, data available/info not empty, |
| | dropped/truncated: 16 bits each, bit 4 x in + out |
| 16-19 | packets forwarded, 8 bits per (in, out) pair |
| 24-26 | primary MAC addresses learned on Eth1 and Eth2 |
| 27 | FPGA forwarding per port: 16 bits each |

Here the switch is quiet: Eth1 and the real-time port are active and fast,
every counter and flag is 0 and no MAC address has been learned.
"""

from __future__ import annotations

SWITCH_DATA = 0x40A0
SWITCH_QUADLETS = 32
FIRST_FIRMWARE = 9
HEADER = int.from_bytes(b"ESW0", "little")
ETH1, RT = 0, 3
#: Port attribute bits: active (3..0) and fast (7..4) for Eth1 and the real-time port.
PORT_ATTRIBUTES = (1 << ETH1 | 1 << RT) | (1 << ETH1 | 1 << RT) << 4


def switch_data(index: int) -> int:
    """Quadlet ``index`` (0..31) of the switch status block."""
    if index == 0:
        return HEADER
    if index == 1:
        return PORT_ATTRIBUTES
    return 0


def switch_index(index: int) -> int | None:
    """Where quadlet index ``index`` falls in the block at 0x40A0, or None."""
    position = index - SWITCH_DATA
    return position if 0 <= position < SWITCH_QUADLETS else None
