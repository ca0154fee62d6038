"""Writing pcapng and classic pcap files (no dependency: both are simple block formats).

A writer emits every block with a single ``write`` call and flushes at
:meth:`flush` and :meth:`close`, so a capture stopped between two packets
leaves a complete file. Reading is in :mod:`fw1394.capture.formats.containers`.
"""

from __future__ import annotations

import struct
from types import TracebackType
from typing import BinaryIO, Self

from fw1394.version import __version__

# -- pcapng block types and option codes (pcapng draft, section 4) -------------------------
SHB_TYPE = 0x0A0D0D0A
IDB_TYPE = 0x00000001
PB_TYPE = 0x00000002  # obsolete Packet Block, still read
SPB_TYPE = 0x00000003
EPB_TYPE = 0x00000006
BYTE_ORDER_MAGIC = 0x1A2B3C4D
OPT_END = 0
OPT_COMMENT = 1
SHB_USERAPPL = 4
IF_NAME = 2
IF_DESCRIPTION = 3
IF_TSRESOL = 9
IF_TSOFFSET = 14
#: EPB header before the packet bytes: type, length, interface, ts high, ts low, caplen, len.
EPB_HEADER_SIZE = 28

# -- classic pcap ---------------------------------------------------------------------------
PCAP_MAGIC_US = 0xA1B2C3D4
PCAP_MAGIC_NS = 0xA1B23C4D
PCAP_HEADER_SIZE = 24
PCAP_RECORD_HEADER_SIZE = 16
DEFAULT_SNAPLEN = 262144

LINKTYPE_NULL = 0
LINKTYPE_ETHERNET = 1
LINKTYPE_RAW = 101
LINKTYPE_LOOP = 108
LINKTYPE_LINUX_SLL = 113
LINKTYPE_IPV4 = 228
LINKTYPE_IPV6 = 229
LINKTYPE_LINUX_SLL2 = 276


def _pad4(data: bytes) -> bytes:
    return data + bytes(-len(data) % 4)


def _option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + _pad4(value)


def _block(block_type: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack("<II", block_type, length) + body + struct.pack("<I", length)


class _Writer:
    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self.packets = 0

    def flush(self) -> None:
        self._stream.flush()

    def close(self) -> None:
        if not self._stream.closed:
            self._stream.flush()
            self._stream.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self,
        kind: type[BaseException] | None,
        value: BaseException | None,
        traceback: TracebackType | None,
    ) -> None:
        self.close()


class PcapngWriter(_Writer):
    """One section, one interface of ``linktype``, nanosecond timestamps."""

    def __init__(
        self,
        stream: BinaryIO,
        linktype: int,
        interface_name: str = "fw1394",
        description: str = "",
        snaplen: int = 0,
    ) -> None:
        super().__init__(stream)
        application = f"fw1394 {__version__}".encode()
        shb_body = struct.pack("<IHHq", BYTE_ORDER_MAGIC, 1, 0, -1)
        shb_body += _option(SHB_USERAPPL, application) + _option(OPT_END, b"")
        idb_body = struct.pack("<HHI", linktype, 0, snaplen)
        idb_body += _option(IF_NAME, interface_name.encode())
        if description:
            idb_body += _option(IF_DESCRIPTION, description.encode())
        idb_body += _option(IF_TSRESOL, bytes([9])) + _option(OPT_END, b"")
        stream.write(_block(SHB_TYPE, shb_body) + _block(IDB_TYPE, idb_body))

    def write(self, timestamp_ns: int, packet: bytes) -> None:
        body = struct.pack(
            "<IIIII",
            0,
            (timestamp_ns >> 32) & 0xFFFFFFFF,
            timestamp_ns & 0xFFFFFFFF,
            len(packet),
            len(packet),
        )
        self._stream.write(_block(EPB_TYPE, body + _pad4(packet)))
        self.packets += 1


class PcapWriter(_Writer):
    """Classic pcap with nanosecond timestamps (magic 0xA1B23C4D), little-endian."""

    def __init__(self, stream: BinaryIO, linktype: int, snaplen: int = DEFAULT_SNAPLEN) -> None:
        super().__init__(stream)
        stream.write(struct.pack("<IHHiIII", PCAP_MAGIC_NS, 2, 4, 0, 0, snaplen, linktype))

    def write(self, timestamp_ns: int, packet: bytes) -> None:
        seconds, nanoseconds = divmod(timestamp_ns, 1_000_000_000)
        header = struct.pack("<IIII", seconds & 0xFFFFFFFF, nanoseconds, len(packet), len(packet))
        self._stream.write(header + packet)
        self.packets += 1


def open_writer(path: str, linktype: int, container: str = "pcapng") -> PcapngWriter | PcapWriter:
    """A writer on a new file; ``container`` is ``pcapng`` or ``pcap``."""
    stream = open(path, "wb")  # noqa: SIM115 - the writer owns and closes it
    if container == "pcap":
        return PcapWriter(stream, linktype)
    return PcapngWriter(stream, linktype)
