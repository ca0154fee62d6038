"""Planted defects of the thesis link RTL, each switched on by a Verilog define."""

from __future__ import annotations

from fw1394.boards.registry import BOARDS
from fw1394.rtl.portmap import PortMap

#: name -> what the defect does (fw1394/rtl/hdl/fw1394_link.v has the code).
RTL_DEFECTS = {
    "no-header-crc": "the header CRC is never compared",
    "any-node": "every destination is taken as this node",
    "unbounded-block": "blocks longer than 2048 bytes are served",
    "early-ack": "a block write is acked from its header, before its data CRC is known",
    "long-hold": "Hold is kept 60 cycles before a read response",
    "long-write-hold": "Hold is kept 60 cycles before a write's ack",
    "no-second-grant": "a read response follows its ack at once, without the PHY's second Grant",
    "no-closing-idle": "the link releases the interface without the closing Idle",
    "bad-crc-write": "a quadlet write whose header CRC fails is performed (ack_data_error)",
}


def define(name: str) -> str:
    """The Verilog define that plants defect ``name``."""
    return "FW1394_DEFECT_" + name.upper().replace("-", "_")


def known_rtl_defects(portmap: PortMap) -> dict[str, str]:
    """Defects a design under ``portmap`` takes: the thesis link's, and those of the
    board serving its register bus."""
    known = {name: f"RTL defect: {text}" for name, text in RTL_DEFECTS.items()}
    entry = BOARDS.get(portmap.model or "") if portmap.served else None
    for name in sorted(entry.defects if entry else ()):
        known[name] = f"board defect of {portmap.model} (docs/boards/)"
    return known
