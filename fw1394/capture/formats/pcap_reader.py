"""Classic pcap in chunks: records walked one by one, resynchronised after damage."""

from __future__ import annotations

import struct
from collections.abc import Iterator
from typing import BinaryIO

import numpy as np

from fw1394.capture.formats.chunks import MAX_RECORD, PADDING, ChunkSource, FormatError, PacketChunk
from fw1394.capture.formats.pcap_writer import (
    PCAP_HEADER_SIZE,
    PCAP_MAGIC_NS,
    PCAP_MAGIC_US,
    PCAP_RECORD_HEADER_SIZE,
)
from fw1394.capture.formats.read_issues import Issue

_I64 = np.int64


class PcapReader:
    """Every record of a classic pcap stream (either byte order, µs or ns), chunk by chunk."""

    def __init__(self, stream: BinaryIO, head: bytes, chunk_size: int) -> None:
        rest = stream.read(PCAP_HEADER_SIZE - 4)
        header = head + rest
        if len(header) < PCAP_HEADER_SIZE:
            raise FormatError("pcap file header is truncated")
        magic = struct.unpack("<I", header[:4])[0]
        self._order = "<" if magic in (PCAP_MAGIC_US, PCAP_MAGIC_NS) else ">"
        magic = struct.unpack(self._order + "I", header[:4])[0]
        self._scale = 1 if magic == PCAP_MAGIC_NS else 1000
        _, _, _, _, self._snaplen, network = struct.unpack(self._order + "HHiIII", header[4:])
        self._linktype = network & 0x0FFFFFFF
        self._source = ChunkSource(stream, b"", chunk_size)
        self._source.file_offset = PCAP_HEADER_SIZE
        self._frame = 1
        self._record = struct.Struct(self._order + "IIII")
        self._last_seconds: int | None = None

    def chunks(self) -> Iterator[PacketChunk]:
        source = self._source
        while (buf := source.next_chunk()) is not None:
            size = len(buf) - PADDING
            base = source.file_offset
            issues: list[Issue] = []
            starts: list[int] = []
            lengths: list[int] = []
            stamps: list[int] = []
            positions: list[int] = []
            pos = 0
            unpack = self._record.unpack_from
            limit = max(self._snaplen, 65536) if self._snaplen else MAX_RECORD
            while size - pos >= PCAP_RECORD_HEADER_SIZE:
                seconds, fraction, caplen, _ = unpack(buf, pos)
                if caplen > limit or caplen > MAX_RECORD:
                    issues.append(Issue(base + pos, f"record length {caplen} is implausible"))
                    pos = self._resync(buf, pos + 1, size, limit)
                    continue
                end = pos + PCAP_RECORD_HEADER_SIZE + caplen
                if end > size:
                    break
                self._last_seconds = seconds
                starts.append(pos + PCAP_RECORD_HEADER_SIZE)
                lengths.append(caplen)
                stamps.append(seconds * 1_000_000_000 + fraction * self._scale)
                positions.append(base + pos)
                pos = end
            if source.eof and pos < size:
                message = f"truncated record ({size - pos} bytes)"
                issues.append(Issue(base + pos, message, cut_short=True))
                pos = size
            source.give_back(buf, pos, size)
            count = len(starts)
            chunk = PacketChunk(
                buf,
                np.array(starts, _I64),
                np.array(lengths, _I64),
                np.array(stamps, _I64),
                np.full(count, self._linktype, np.int32),
                np.array(positions, _I64),
                self._frame,
                issues,
            )
            self._frame += count
            if count or issues:
                yield chunk

    def _resync(self, buf: bytearray, pos: int, size: int, limit: int) -> int:
        """The next offset where three records in a row look sane (or the end of data)."""
        while size - pos >= PCAP_RECORD_HEADER_SIZE:
            if self._plausible(buf, pos, size, limit, 3):
                return pos
            pos += 1
        return pos

    def _plausible(self, buf: bytearray, pos: int, size: int, limit: int, depth: int) -> bool:
        if depth == 0:
            return True
        if size - pos < PCAP_RECORD_HEADER_SIZE:
            # The chain ran to the end of the data (_resync saw room for the first record).
            return True
        seconds, fraction, caplen, original = self._record.unpack_from(buf, pos)
        if not (caplen <= limit and caplen <= original <= MAX_RECORD and fraction < 1_000_000_000):
            return False
        if self._last_seconds is not None and abs(seconds - self._last_seconds) > 86_400:
            return False
        end = pos + PCAP_RECORD_HEADER_SIZE + caplen
        return end <= size and self._plausible(buf, end, size, limit, depth - 1)
