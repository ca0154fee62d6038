"""The FPGA V3's two Ethernet PHYs (RTL8211F) behind their MDIO windows.

The host library reaches PHY ``chan`` (1 or 2) through the quadlet at
``0x40A0 | chan << 8`` (0x41A0, 0x42A0), in the Ethernet space (FpgaIO's
RTL8211F helpers; jhu-eth1394.md §4.1):

* a write is an IEEE 802.3 clause-22 management frame: bits 31..30 start (01),
  29..28 operation (10 read, 01 write), 27..23 PHY address, 22..18 register,
  17..16 turnaround (10 on a write), 15..0 data;
* a read is the interface: bits 26..24 busy (0: idle, here always, since
  every frame completes at once), 20..16 the register of the last read,
  15..0 its data.

Behind each window: the RTL8211F at PHY address 1 (and at 0, the broadcast
address it also answers), and the FPGA's GMII-to-RGMII core at address 8.
The RTL8211F registers as data (:data:`RTL8211F_RESET`): registers 0-15 are
IEEE ones on every page, 16-30 belong to the page register 31 selects
(power-up page 0xA42). Identification 0x001C / 0xC916; basic status and PHY
status report a 1000 Mbit/s full-duplex link (the FPGA's port status says
so too). Reads of an address nothing answers give 0xFFFF (the MDIO line's
pull-up).
"""

from __future__ import annotations

from dataclasses import dataclass, field

MDIO_WINDOW = 0x40A0
MDIO_CHANNELS = (1, 2)
OPERATION_READ, OPERATION_WRITE = 0b10, 0b01
RTL8211F_ADDRESSES = (0, 1)
GMII_CORE_ADDRESS = 8
NOBODY = 0xFFFF
PAGE_SELECT = 31
DEFAULT_PAGE = 0x0A42
IEEE_REGISTERS = 16

BMCR, BMSR, PHYID1, PHYID2, ANAR = 0, 1, 2, 3, 4
BMCR_RESET = 1 << 15
INER, PHYSR = 18, 26

#: Power-up values: (page, register) -> value; page None: an IEEE register.
RTL8211F_RESET: dict[tuple[int | None, int], int] = {
    (None, BMCR): 0x1140,  # auto-negotiation on, full duplex, 1000 Mbit/s selected
    (None, BMSR): 0x796D,  # capabilities, auto-negotiation complete, link up
    (None, PHYID1): 0x001C,  # Realtek OUI bits 3..18
    (None, PHYID2): 0xC916,  # OUI bits 19..24, model 0x11, revision 6
    (None, ANAR): 0x01E1,
    (0x0A42, INER): 0x0000,
    (0x0A43, PHYSR): 0x002C,  # link good, full duplex, 1000 Mbit/s
    (0x0A42, PHYSR): 0x002C,  # (the library reads it on the power-up page as well)
    (0x0D08, 17): 0x0100,  # RGMII transmit delay on
    (0x0D08, 21): 0x0008,  # RGMII receive delay on
}
#: Registers a write leaves alone: identification and status.
READ_ONLY: frozenset[tuple[int | None, int]] = frozenset(
    {(None, BMSR), (None, PHYID1), (None, PHYID2), (0x0A43, PHYSR), (0x0A42, PHYSR)}
)


@dataclass
class Rtl8211f:
    """One RTL8211F's management registers."""

    page: int = DEFAULT_PAGE
    registers: dict[tuple[int | None, int], int] = field(
        default_factory=lambda: dict(RTL8211F_RESET)
    )

    def _key(self, register: int) -> tuple[int | None, int]:
        return (None, register) if register < IEEE_REGISTERS else (self.page, register)

    def read(self, register: int) -> int:
        if register == PAGE_SELECT:
            return self.page
        return self.registers.get(self._key(register), 0)

    def write(self, register: int, value: int) -> None:
        if register == PAGE_SELECT:
            self.page = value
            return
        key = self._key(register)
        if key in READ_ONLY:
            return
        if key == (None, BMCR) and value & BMCR_RESET:
            # A software reset puts the registers back and clears itself.
            self.page, self.registers = DEFAULT_PAGE, dict(RTL8211F_RESET)
            return
        self.registers[key] = value & 0xFFFF


@dataclass
class MdioWindow:
    """One channel's management interface: its PHY, the RGMII core, the last read."""

    phy: Rtl8211f = field(default_factory=Rtl8211f)
    core: dict[int, int] = field(default_factory=dict)
    last_register: int = 0
    last_data: int = 0

    def write(self, frame: int) -> None:
        operation = frame >> 28 & 0b11
        address, register, data = frame >> 23 & 0x1F, frame >> 18 & 0x1F, frame & 0xFFFF
        if operation == OPERATION_READ:
            self.last_register, self.last_data = register, self._read(address, register)
        elif operation == OPERATION_WRITE:
            if address in RTL8211F_ADDRESSES:
                self.phy.write(register, data)
            elif address == GMII_CORE_ADDRESS:
                self.core[register] = data

    def _read(self, address: int, register: int) -> int:
        if address in RTL8211F_ADDRESSES:
            return self.phy.read(register)
        if address == GMII_CORE_ADDRESS:
            return self.core.get(register, 0)
        return NOBODY

    def read(self) -> int:
        """The interface: idle, the last register read and its data."""
        return self.last_register << 16 | self.last_data


def mdio_channel(index: int) -> int | None:
    """The PHY channel whose window is at quadlet ``index`` (0x41A0, 0x42A0), or None."""
    channel = index >> 8 & 0xF
    if index & ~0x0F00 == MDIO_WINDOW and channel in MDIO_CHANNELS:
        return channel
    return None
