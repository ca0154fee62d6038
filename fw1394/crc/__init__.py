"""IEEE 1394 CRCs.

The header CRC and the data CRC of asynchronous packets are both CRC-32 with
polynomial 0x04C11DB7, initial register all ones, no reflection and a final
complement (catalogue name CRC-32/BZIP2), fed with the big-endian bytes of the
quadlets exactly as they are transmitted. The configuration ROM uses the
IEEE 1212 CRC-16 (polynomial 0x1021, initial value 0, MSB first), which is the
same function as CRC-16/XMODEM over the big-endian bytes.
"""

from __future__ import annotations

from collections.abc import Callable

import crcmod

__all__ = ["CHECK_VALUE", "crc16_1212", "crc32", "data_crc", "header_crc", "padded"]

# crcmod's ``initCrc`` is the register's initial value already XOR-ed with
# ``xorOut``: all ones XOR all ones is 0.
crc32: Callable[[bytes], int] = crcmod.mkCrcFun(
    0x104C11DB7, initCrc=0, rev=False, xorOut=0xFFFFFFFF
)
crc16_1212: Callable[[bytes], int] = crcmod.mkCrcFun(0x11021, initCrc=0, rev=False, xorOut=0)
crc32.__doc__ = "CRC-32/BZIP2 of ``data``: the 1394 header and data CRC before padding."
crc16_1212.__doc__ = "IEEE 1212 CRC-16 of ``data``: the configuration ROM's CRC."

#: CRC-32/BZIP2 of ASCII "123456789", the catalogue check value.
CHECK_VALUE = 0xFC891918


def padded(data: bytes) -> bytes:
    """``data`` zero-padded to a quadlet boundary, as it travels in a data block."""
    remainder = len(data) % 4
    return data + bytes(4 - remainder) if remainder else data


def header_crc(header: bytes) -> int:
    """Header CRC over the header quadlets (big-endian bytes) that precede it."""
    return crc32(header)


def data_crc(data: bytes) -> int:
    """Data CRC over a data block, padded to a quadlet boundary first."""
    return crc32(padded(data))
