"""CSR registers and configuration ROM: the one byte-addressed window of the board.

Offsets 0xFFFF_F000_0000..0FFF are decoded by the FireWire link itself, with
byte addresses (a block read steps by 4). Contents follow FireWire.v of the
JHU firmware (general ROM format, read from the Verilog): a bus-info block
carrying the JHU LCSR company id, the board id and the firmware version, a
root directory, and vendor ("JHU LCSR") and model ("FPGAn/QLA") text leaves.
The CRC-16 of each block is the IEEE 1212 one; the firmware's hard-coded
values match it.
"""

from __future__ import annotations

from dataclasses import dataclass

import crcmod

from fw1394.packets.nodeid import LOCAL_BUS

#: offset bits 47..12 of the CSR / configuration ROM window.
CSR_WINDOW_PREFIX = 0xFFFFF0000
CSR_WINDOW_SHIFT = 12
CSR_BYTE_MASK = 0xFFF

STATE_CLEAR = 0x000
STATE_SET = 0x004
NODE_IDS = 0x008
SPLIT_TIMEOUT_HI = 0x018
SPLIT_TIMEOUT_LO = 0x01C
ROM_BASE = 0x400

#: IEEE-assigned company id of JHU LCSR.
JHU_LCSR_COMPANY_ID = 0xFA610E
#: Bus options quadlet the firmware sends (it says "should be default values").
BUS_OPTIONS = 0x00FFA000
#: Root directory node capabilities: split timeout, 64-bit and fixed addressing...
NODE_CAPABILITIES = 0x0083C0
POWER_UP_SPLIT_TIMEOUT_LO = 800  # in units of 125 us, bits 31..19 of the register

_crc16 = crcmod.mkCrcFun(0x11021, initCrc=0, rev=False, xorOut=0)


def in_csr_window(offset: int) -> bool:
    return offset >> CSR_WINDOW_SHIFT == CSR_WINDOW_PREFIX


def _text(text: bytes) -> list[int]:
    padded = text + bytes(-len(text) % 4)
    return [int.from_bytes(padded[i : i + 4], "big") for i in range(0, len(padded), 4)]


def _block(body: list[int], length_field: int | None = None) -> list[int]:
    """A ROM block: {length 31..16, CRC-16 of the body 15..0}, then the body."""
    data = b"".join(q.to_bytes(4, "big") for q in body)
    length = len(body) if length_field is None else length_field
    return [(length << 16) | _crc16(data), *body]


def _bus_info_block(board_id: int, firmware: int, has_ethernet: bool) -> list[int]:
    build = 0xE if has_ethernet else 0xF  # the firmware's "Ethernet build" nibble
    body = [
        int.from_bytes(b"1394", "big"),
        BUS_OPTIONS,
        (JHU_LCSR_COMPANY_ID << 8) | (board_id << 4) | build,
        firmware,
    ]
    # Header: info_length 4 and crc_length 4 in the two high bytes.
    return _block(body, length_field=0x0404)


def build_config_rom(board_id: int, firmware: int, has_ethernet: bool) -> list[int]:
    """The quadlets at ROM_BASE, ROM_BASE + 4, ..."""
    revision = 2 if has_ethernet else 1
    vendor_leaf = _block([0, 0, *_text(b"JHU LCSR")])
    model_leaf = _block([0, 0, *_text(b"FPGA%d/QLA" % revision)])
    root_directory = _block(
        [
            0x0C << 24 | NODE_CAPABILITIES,
            0x03 << 24 | JHU_LCSR_COMPANY_ID,
            0x81 << 24 | 3,  # vendor leaf, 3 quadlets further on
            0x17 << 24 | revision,  # model id
            0x81 << 24 | 6,  # model leaf, 6 quadlets further on
        ]
    )
    return (
        _bus_info_block(board_id, firmware, has_ethernet)
        + root_directory
        + vendor_leaf
        + model_leaf
    )


@dataclass
class CsrSpace:
    """The writable CSR registers and the (read-only) configuration ROM."""

    rom: list[int]
    node_id: int = 0
    bus_id: int = LOCAL_BUS
    state: int = 0
    split_timeout_seconds: int = 0
    split_timeout_fraction: int = POWER_UP_SPLIT_TIMEOUT_LO

    def read(self, address: int) -> int:
        """Quadlet at byte ``address`` (0..0xFFF); 0 where nothing is defined."""
        if address in (STATE_CLEAR, STATE_SET):
            return self.state
        if address == NODE_IDS:
            return (self.bus_id << 22) | (self.node_id << 16)
        if address == SPLIT_TIMEOUT_HI:
            return self.split_timeout_seconds
        if address == SPLIT_TIMEOUT_LO:
            return self.split_timeout_fraction << 19
        index, misaligned = divmod(address - ROM_BASE, 4)
        if not misaligned and 0 <= index < len(self.rom):
            return self.rom[index]
        return 0

    def write(self, address: int, value: int) -> None:
        # Bits 1..0 of the state register are not writable in the firmware.
        if address == STATE_CLEAR:
            self.state &= ~(value & ~3)
        elif address == STATE_SET:
            self.state |= value & ~3
        elif address == NODE_IDS:
            self.bus_id = value >> 22
        elif address == SPLIT_TIMEOUT_HI:
            self.split_timeout_seconds = value & 0x7
        elif address == SPLIT_TIMEOUT_LO:
            self.split_timeout_fraction = (value >> 19) & 0x1FFF
