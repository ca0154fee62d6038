"""The board's two PROMs behind the registers the JHU host library drives.

**Configuration PROM (M25P16, 2 MiB, 32 sectors of 64 KiB, 256-byte pages).**
Register 8 (PROM_STATUS) takes a command: the M25P16 instruction in bits
31..24 and, where it needs one, the 24-bit PROM address in 23..0. A read of
register 8 is the interface status (bits 3..0 busy, 31..24 error; here every
command finishes at once, so 0), register 9 (PROM_RESULT) the command's
result, and the page buffer sits at 0x2000 (64 quadlets, bytes in PROM order
as big-endian quadlets on the wire) for firmware 4 on (jhu-eth1394.md §4.1-4.2,
§4.10; the host's FpgaIO):

* read identification, 0x9F000000: result the JEDEC ID 0x202015 (ST, serial
  flash, 16 Mbit);
* read status, 0x05000000: the status register, bit 0 write in progress,
  bit 1 write enabled;
* write enable / disable, 0x06000000 / 0x04000000;
* read data, 0x03000000 | address: 256 bytes from the address into the page
  buffer, result 64 (quadlets);
* sector erase, 0xD8000000 | address (needs write enable): the 64 KiB
  sector reads 0xFF; bulk erase, 0xC7000000: everything does;
* page program: a block write to 0x2000 of {0x02000000 | address, up to 64
  data quadlets} (needs write enable): bits only go from 1 to 0, the address
  wraps inside its 256-byte page, result 1 + data quadlets.

Erase and program leave the chip busy (status bit 0) for a while, then clear
write enable, as the M25P16 does; the durations here are this model's
(:data:`ERASE_TICKS`, :data:`PROGRAM_TICKS`), far shorter than the chip's.

**QLA PROM (25AA128, 16 KiB)**, at 0x3000 (command), 0x3002 (result) and
0x3100 (16-quadlet buffer): 0x03000000 | address << 8 reads one byte (the
result's bits 7..0), 0xFE000000 | address << 8 | (quadlets - 1) reads up to
16 quadlets into the buffer, 0x06000000 enables writing, 0x02000000 | address
<< 8 | byte writes one byte, 0xFF000000 | address << 8 | (quadlets - 1)
writes the buffer, 0x05000000 reads the status (FpgaIO.cpp, the 25AA128
helpers). It holds the QLA serial number ("QLA 1234-56") at address 0.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import IntEnum

#: JEDEC identification of the M25P16: manufacturer 0x20, memory type 0x20, 16 Mbit.
M25P16_ID = 0x202015
PROM_BYTES = 1 << 21
SECTOR_BYTES = 1 << 16
PAGE_BYTES = 256
PAGE_QUADLETS = PAGE_BYTES // 4
ADDRESS_MASK = 0xFFFFFF
STATUS_WRITE_IN_PROGRESS = 1 << 0
STATUS_WRITE_ENABLED = 1 << 1
#: 49.152 MHz board ticks a sector erase and a page program keep the chip busy.
ERASE_TICKS = 49_152  # 1 ms
PROGRAM_TICKS = 4_915  # 0.1 ms
#: Where the FPGA serial number is kept ("FPGA 1234-56", then 0xFF).
FPGA_SERIAL_ADDRESS = 0x1FFF00
ERASED = 0xFF


class Instruction(IntEnum):
    """M25P16 instructions the firmware passes on (bits 31..24 of a command)."""

    PAGE_PROGRAM = 0x02
    READ_DATA = 0x03
    WRITE_DISABLE = 0x04
    READ_STATUS = 0x05
    WRITE_ENABLE = 0x06
    BULK_ERASE = 0xC7
    SECTOR_ERASE = 0xD8
    READ_ID = 0x9F


@dataclass
class ConfigProm:
    """The M25P16 and the FPGA's interface to it (registers 8, 9 and the page buffer)."""

    #: Sectors ever written, by sector number; an absent one reads erased (0xFF).
    sectors: dict[int, bytearray] = field(default_factory=dict)
    write_enabled: bool = False
    busy_until: int = 0
    result: int = 0
    page: list[int] = field(default_factory=lambda: [0] * PAGE_QUADLETS)

    # -- the chip ------------------------------------------------------------------------
    def read_bytes(self, address: int, count: int) -> bytes:
        out = bytearray()
        for position in range(address, address + count):
            position %= PROM_BYTES
            sector = self.sectors.get(position // SECTOR_BYTES)
            out.append(ERASED if sector is None else sector[position % SECTOR_BYTES])
        return bytes(out)

    def _sector(self, number: int) -> bytearray:
        if number not in self.sectors:
            self.sectors[number] = bytearray([ERASED]) * SECTOR_BYTES
        return self.sectors[number]

    def store(self, address: int, data: bytes) -> None:
        """Program ``data`` at ``address`` as the chip does: bits go from 1 to 0 only."""
        for offset, value in enumerate(data):
            position = (address + offset) % PROM_BYTES
            sector = self._sector(position // SECTOR_BYTES)
            sector[position % SECTOR_BYTES] &= value

    def status(self, now: int) -> int:
        busy = now < self.busy_until
        if not busy and self.busy_until:
            self.busy_until = 0
            self.write_enabled = False  # the chip clears it when the write ends
        return (STATUS_WRITE_IN_PROGRESS if busy else 0) | (
            STATUS_WRITE_ENABLED if self.write_enabled else 0
        )

    def _start_write(self, now: int, ticks: int) -> bool:
        """A write may start: enabled and not busy; the chip is busy for ``ticks``."""
        if not self.write_enabled or self.status(now) & STATUS_WRITE_IN_PROGRESS:
            return False
        self.busy_until = now + ticks
        return True

    # -- registers 8, 9 and the buffer at 0x2000 -----------------------------------------
    def command(self, value: int, now: int) -> None:
        """A write to register 8."""
        instruction, address = value >> 24, value & ADDRESS_MASK
        if instruction == Instruction.READ_ID:
            self.result = M25P16_ID
        elif instruction == Instruction.READ_STATUS:
            self.result = self.status(now)
        elif instruction == Instruction.WRITE_ENABLE:
            if not self.status(now) & STATUS_WRITE_IN_PROGRESS:
                self.write_enabled = True
        elif instruction == Instruction.WRITE_DISABLE:
            if not self.status(now) & STATUS_WRITE_IN_PROGRESS:
                self.write_enabled = False
        elif instruction == Instruction.READ_DATA:
            data = self.read_bytes(address, PAGE_BYTES)
            self.page = [int.from_bytes(data[n : n + 4], "big") for n in range(0, PAGE_BYTES, 4)]
            self.result = PAGE_QUADLETS
        elif instruction == Instruction.SECTOR_ERASE:
            if self._start_write(now, ERASE_TICKS):
                self.sectors.pop((address % PROM_BYTES) // SECTOR_BYTES, None)
        elif instruction == Instruction.BULK_ERASE and self._start_write(now, ERASE_TICKS):
            self.sectors.clear()

    def interface_status(self) -> int:
        """A read of register 8: the FPGA's interface is idle (it finished the command)."""
        return 0

    def buffer_read(self, index: int) -> int:
        return self.page[index] if 0 <= index < PAGE_QUADLETS else 0

    def program(self, words: list[int], now: int) -> None:
        """A block write to 0x2000: the page-program command, then the data."""
        command, data = words[0], words[1 : 1 + PAGE_QUADLETS]
        if command >> 24 != Instruction.PAGE_PROGRAM:
            return
        self.result = 1 + len(data)
        if not self._start_write(now, PROGRAM_TICKS):
            return
        address = command & ADDRESS_MASK
        page_start = address - address % PAGE_BYTES
        raw = b"".join(word.to_bytes(4, "big") for word in data)
        for offset, value in enumerate(raw):
            # Past the end of its page the chip wraps to the page's start.
            self.store(page_start + (address + offset) % PAGE_BYTES, bytes([value]))


def with_fpga_serial(prom: ConfigProm, serial: str) -> ConfigProm:
    """``prom`` holding ``serial`` ("FPGA 1234-56") where the host library reads it."""
    prom.store(FPGA_SERIAL_ADDRESS, serial.encode("ascii"))
    return prom


# -- the QLA's 25AA128 ---------------------------------------------------------------------

QLA_PROM_BYTES = 1 << 14
QLA_BUFFER_QUADLETS = 16
QLA_READ_BYTE = 0x03
QLA_WRITE_BYTE = 0x02
QLA_WRITE_ENABLE = 0x06
QLA_READ_STATUS = 0x05
QLA_READ_BLOCK = 0xFE
QLA_WRITE_BLOCK = 0xFF


@dataclass
class QlaProm:
    """The QLA's serial-number PROM (0x3000 command, 0x3002 result, 0x3100 buffer)."""

    memory: bytearray = field(default_factory=lambda: bytearray([ERASED]) * QLA_PROM_BYTES)
    write_enabled: bool = False
    result: int = 0
    buffer: list[int] = field(default_factory=lambda: [0] * QLA_BUFFER_QUADLETS)

    def command(self, value: int) -> None:
        instruction = value >> 24
        address = (value >> 8) & (QLA_PROM_BYTES - 1)
        count = (value & 0xF) + 1
        if instruction == QLA_READ_BYTE:
            self.result = self.memory[address]
        elif instruction == QLA_READ_STATUS:
            self.result = 0x02 if self.write_enabled else 0
        elif instruction == QLA_WRITE_ENABLE:
            self.write_enabled = True
        elif instruction == QLA_READ_BLOCK:
            data = bytes(self.memory[(address + n) % QLA_PROM_BYTES] for n in range(4 * count))
            for n in range(count):
                self.buffer[n] = int.from_bytes(data[4 * n : 4 * n + 4], "big")
        elif instruction in (QLA_WRITE_BYTE, QLA_WRITE_BLOCK) and self.write_enabled:
            if instruction == QLA_WRITE_BYTE:
                data = bytes([value & 0xFF])
            else:
                data = b"".join(word.to_bytes(4, "big") for word in self.buffer[:count])
            for n, byte in enumerate(data):
                self.memory[(address + n) % QLA_PROM_BYTES] = byte
            self.write_enabled = False

    def buffer_read(self, index: int) -> int:
        return self.buffer[index] if 0 <= index < QLA_BUFFER_QUADLETS else 0

    def buffer_write(self, index: int, value: int) -> None:
        if 0 <= index < QLA_BUFFER_QUADLETS:
            self.buffer[index] = value


def qla_prom_with_serial(serial: str) -> QlaProm:
    prom = QlaProm()
    data = serial.encode("ascii")
    prom.memory[: len(data)] = data
    return prom
