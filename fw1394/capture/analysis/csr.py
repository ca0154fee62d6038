"""Names of the IEEE 1212 / 1394 CSR registers in initial register space.

Offsets are relative to 0xFFFF_F000_0000, the start of initial register
space on every node; the configuration ROM is at 0x400-0x7FF of it.
"""

from __future__ import annotations

#: Start of initial register space (CSR space).
CSR_BASE = 0xFFFF_F000_0000
CONFIG_ROM = 0x400
CONFIG_ROM_END = 0x800

_REGISTERS: dict[int, str] = {
    0x000: "STATE_CLEAR",
    0x004: "STATE_SET",
    0x008: "NODE_IDS",
    0x00C: "RESET_START",
    0x018: "SPLIT_TIMEOUT_HI",
    0x01C: "SPLIT_TIMEOUT_LO",
    0x020: "ARGUMENT_HI",
    0x024: "ARGUMENT_LO",
    0x028: "TEST_START",
    0x02C: "TEST_STATUS",
    0x050: "INTERRUPT_TARGET",
    0x054: "INTERRUPT_MASK",
    0x200: "CYCLE_TIME",
    0x204: "BUS_TIME",
    0x208: "POWER_FAIL_IMMINENT",
    0x20C: "POWER_SOURCE",
    0x210: "BUSY_TIMEOUT",
    0x218: "PRIORITY_BUDGET",
    0x21C: "BUS_MANAGER_ID",
    0x220: "BANDWIDTH_AVAILABLE",
    0x224: "CHANNELS_AVAILABLE_HI",
    0x228: "CHANNELS_AVAILABLE_LO",
    0x230: "MAINT_UTILITY",
    0x234: "BROADCAST_CHANNEL",
    0x900: "oMPR",
    0x980: "iMPR",
}
#: (first, end, name) of register ranges.
_RANGES = (
    (CONFIG_ROM, CONFIG_ROM_END, "config ROM"),
    (0x904, 0x980, "oPCR"),
    (0x984, 0xA00, "iPCR"),
    (0xB00, 0xD00, "FCP_COMMAND"),
    (0xD00, 0xF00, "FCP_RESPONSE"),
    (0x1000, 0x1400, "TOPOLOGY_MAP"),
    (0x2000, 0x3000, "SPEED_MAP"),
)


def is_csr(offset: int) -> bool:
    return offset >= CSR_BASE


def csr_name(offset: int) -> str | None:
    """A register name for a 48-bit offset in CSR space, None outside it."""
    if offset < CSR_BASE:
        return None
    relative = offset - CSR_BASE
    if relative in _REGISTERS:
        return _REGISTERS[relative]
    for first, end, name in _RANGES:
        if first <= relative < end:
            return f"{name}+{relative - first:#x}"
    return f"CSR+{relative:#x}"
