"""Streaming pcap and pcapng reader: packets in chunks, bounded memory, never raises.

Files are read in chunks of a few megabytes (:mod:`fw1394.capture.formats.chunks`);
pcapng chunks are parsed mostly with numpy (:mod:`fw1394.capture.formats.pcapng_reader`),
classic pcap record by record (:mod:`fw1394.capture.formats.pcap_reader`). Malformed
input becomes an :class:`Issue` with its byte position, and reading resumes at
the next plausible block or record.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from typing import BinaryIO

from fw1394.capture.formats.chunks import CHUNK_SIZE, FormatError, PacketChunk
from fw1394.capture.formats.pcap_reader import PcapReader
from fw1394.capture.formats.pcap_writer import PCAP_MAGIC_NS, PCAP_MAGIC_US, SHB_TYPE
from fw1394.capture.formats.pcapng_reader import PcapngReader
from fw1394.capture.formats.read_issues import Issue

__all__ = ["CHUNK_SIZE", "FormatError", "Issue", "PacketChunk", "read_chunks", "sniff"]


def sniff(head: bytes) -> str | None:
    """``pcapng``, ``pcap`` or None from a file's first four bytes."""
    if len(head) < 4:
        return None
    if head[:4] == struct.pack("<I", SHB_TYPE):
        return "pcapng"
    magic = struct.unpack("<I", head[:4])[0]
    swapped = struct.unpack(">I", head[:4])[0]
    if PCAP_MAGIC_US in (magic, swapped) or PCAP_MAGIC_NS in (magic, swapped):
        return "pcap"
    return None


def read_chunks(stream: BinaryIO, chunk_size: int = CHUNK_SIZE) -> Iterator[PacketChunk]:
    """Every packet of a pcap or pcapng stream, chunk by chunk."""
    head = stream.read(4)
    kind = sniff(head)
    if kind == "pcapng":
        yield from PcapngReader(stream, head, chunk_size).chunks()
    elif kind == "pcap":
        yield from PcapReader(stream, head, chunk_size).chunks()
    else:
        raise FormatError("not a pcap or pcapng file")
