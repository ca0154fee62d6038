"""The FW_PHY_REQ / FW_PHY_RESP pair and a tiny PHY register file behind it.

The host reaches the board's 1394 PHY through two registers. Writing
FW_PHY_REQ (1) starts a PHY register access: ``bit 12 set, register in
bits 11..8, data in bits 7..0`` writes a PHY register; with bit 12 clear the
value is the number of the register to read (the host writes 0 to read PHY
register 0 and 1 to read register 1). The answer of a read lands in
FW_PHY_RESP (2) as ``status 15..12 | register 11..8 | value 7..0``. The host's
gap-count exchange needs PHY register 1 (gap count in bits 5..0, 63 after
power-up). The other values are those of a typical 2-port S400 PHY; nothing
else reads them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

PHY_REQUEST_WRITE = 1 << 12
PHY_REGISTER_SHIFT = 8
PHY_REGISTER_COUNT = 16
#: PHY register 1: root hold-off (bit 7), initiate bus reset (bit 6), gap count.
GAP_COUNT_MASK = 0x3F
INITIATE_BUS_RESET = 0x40
POWER_UP_GAP_COUNT = 63
#: PHY register 0: physical id in bits 7..2, "cable power present" in bit 0.
PHYSICAL_ID_SHIFT = 2
CABLE_POWER_PRESENT = 0x01


def _power_up_registers() -> list[int]:
    registers = [0] * PHY_REGISTER_COUNT
    registers[1] = POWER_UP_GAP_COUNT
    registers[2] = 0xE2  # extended register map, 2 ports
    registers[3] = 0x40  # S400 capable
    return registers


@dataclass
class PhyInterface:
    """FW_PHY_REQ (last value written) and FW_PHY_RESP with the PHY behind them."""

    node_id: int = 0
    request: int = 0
    response: int = 0
    registers: list[int] = field(default_factory=_power_up_registers)

    def register_value(self, number: int) -> int:
        if number == 0:
            return (self.node_id << PHYSICAL_ID_SHIFT) | CABLE_POWER_PRESENT
        return self.registers[number]

    def write_request(self, value: int) -> None:
        """A write to FW_PHY_REQ: remember it and run the PHY access it encodes."""
        self.request = value & 0xFFFF
        if value & PHY_REQUEST_WRITE:
            number, data = (value >> PHY_REGISTER_SHIFT) & 0xF, value & 0xFF
            if number != 0:  # register 0 is read-only (the PHY assigns the node id)
                # Bus resets are the bus's business; the reset request bit does not stick.
                self.registers[number] = data & ~INITIATE_BUS_RESET if number == 1 else data
            return
        # A read answers with a register status transfer, which the link stores.
        number = value & 0xF
        self.response = (number << PHY_REGISTER_SHIFT) | self.register_value(number)

    def write_response(self, value: int) -> None:
        """FW_PHY_RESP is writable too (the firmware keeps the low 16 bits)."""
        self.response = value & 0xFFFF

    @property
    def gap_count(self) -> int:
        return self.registers[1] & GAP_COUNT_MASK
