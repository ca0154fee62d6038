"""IEEE 1394's CRC-32, written from the standard for tests to check fw1394 against.

Polynomial 0x04C11DB7, most significant bit first, preset to all ones and
inverted at the end, no reflection (the same CRC as CRC-32/BZIP2; the JHU
spec §1.5 names it so). It shares no code with ``fw1394.crc`` on purpose: a
test that checks the library's CRC with the library's CRC cannot fail.
"""

from __future__ import annotations


def crc32_1394(data: bytes) -> int:
    """The CRC-32 of ``data``, bit by bit as the standard describes it."""
    crc = 0xFFFFFFFF
    for byte in data:
        crc ^= byte << 24
        for _ in range(8):
            crc = (crc << 1) ^ 0x04C11DB7 if crc & 0x80000000 else crc << 1
            crc &= 0xFFFFFFFF
    return crc ^ 0xFFFFFFFF
