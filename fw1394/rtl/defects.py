"""Planted defects of the thesis link RTL, each switched on by a Verilog define."""

from __future__ import annotations

#: name -> what the defect does (fw1394/rtl/hdl/fw1394_link.v has the code).
RTL_DEFECTS = {
    "no-header-crc": "the header CRC is never compared",
    "any-node": "every destination is taken as this node",
    "unbounded-block": "blocks longer than 2048 bytes are served",
    "early-ack": "a block write is acked from its header, before its data CRC is known",
    "long-hold": "Hold is kept 60 cycles before a read response",
}


def define(name: str) -> str:
    """The Verilog define that plants defect ``name``."""
    return "FW1394_DEFECT_" + name.upper().replace("-", "_")
