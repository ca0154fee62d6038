"""The DS2505 1-wire memory of a dVRK instrument, behind register 13 and 0x6000.

What the host library's Dallas helpers and ``instrument`` use (jhu-eth1394.md
§4.2, §4.10; AmpIO's Dallas methods), firmware 7 on:

* a write of register 13 is a control word: ``address << 16 | 2`` reads the
  256 bytes from ``address`` into the block buffer at 0x6000, ``3`` the next
  256 bytes (bit 2 asks for the DS2480B serial interface: ignored here);
* a read of register 13 is the status: bit 0 interface enabled, bits 2..1 the
  1-wire reset result (1: the chip answered), bit 3 DOUT bidirectional,
  bits 8..4 state and bit 13 busy (0: idle, here at once), bit 15 DS2480B in
  use (0), bits 23..16 the measured rise time in 49.152 MHz ticks, bits
  31..24 the family code the chip reported (0x0B, a DS2505);
* a block read of 0x6000 returns the buffer, bytes in memory order.

The memory (2 KiB) holds what :data:`DEFAULT_CONTENTS` says unless given.
"""

from __future__ import annotations

from dataclasses import dataclass, field

MEMORY_BYTES = 2048
BLOCK_BYTES = 256
BUFFER_BASE = 0x6000
FIRST_FIRMWARE = 7
CONTROL_READ_AT, CONTROL_READ_NEXT = 2, 3
ENABLED = 1 << 0
RESET_ANSWERED = 1 << 1  # bits 2..1 = 1
DOUT_BIDIRECTIONAL = 1 << 3
RISE_TIME_TICKS = 0x20
FAMILY_DS2505 = 0x0B
#: An instrument memory: a name the emulator wrote, the rest erased (0xFF).
DEFAULT_CONTENTS = b"fw1394 emulated instrument\0".ljust(MEMORY_BYTES, b"\xff")


@dataclass
class Ds2505:
    """The chip and the FPGA's 1-wire interface to it."""

    memory: bytes = DEFAULT_CONTENTS
    address: int = 0
    buffer: bytes = field(default_factory=lambda: bytes(BLOCK_BYTES))
    read_once: bool = False

    def control(self, value: int) -> None:
        """A write to register 13."""
        operation = value & 0b11
        if operation == CONTROL_READ_AT:
            self.address = (value >> 16) % MEMORY_BYTES
        elif operation == CONTROL_READ_NEXT:
            self.address = (self.address + BLOCK_BYTES) % MEMORY_BYTES
        else:
            return
        self.read_once = True
        end = self.address + BLOCK_BYTES
        self.buffer = (self.memory + self.memory)[self.address : end]

    def status(self) -> int:
        """A read of register 13."""
        if not self.read_once:
            return ENABLED | DOUT_BIDIRECTIONAL  # nothing asked of the chip yet
        return (
            FAMILY_DS2505 << 24
            | RISE_TIME_TICKS << 16
            | DOUT_BIDIRECTIONAL
            | RESET_ANSWERED
            | ENABLED
        )

    def buffer_read(self, index: int) -> int:
        if not 0 <= index < BLOCK_BYTES // 4:
            return 0
        return int.from_bytes(self.buffer[4 * index : 4 * index + 4], "big")
