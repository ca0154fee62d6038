"""Pieces shared by the pcap and pcapng readers: chunks, issues, buffered reading."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import BinaryIO

import numpy as np

from fw1394.capture.formats.read_issues import Issue
from fw1394.errors import PacketError

CHUNK_SIZE = 4 << 20
#: Zero bytes after every chunk so header gathers near its end stay in bounds.
PADDING = 64
#: A record this long is taken as corruption, not a packet.
MAX_RECORD = 1 << 24


@dataclass
class PacketChunk:
    """Packets found in one chunk of a file, as columns over the chunk's bytes."""

    buf: bytearray
    start: np.ndarray  # byte offset of each packet in ``buf``
    length: np.ndarray  # captured bytes
    ts_ns: np.ndarray
    linktype: np.ndarray
    position: np.ndarray  # byte offset of the block or record in the file
    first_frame: int  # 1-based number of the first packet in the file
    issues: list[Issue] = field(default_factory=list)

    def __len__(self) -> int:
        return len(self.start)

    def packet(self, index: int) -> bytes:
        begin = int(self.start[index])
        return bytes(self.buf[begin : begin + int(self.length[index])])


class FormatError(PacketError):
    """The file is neither pcap nor pcapng."""


class ChunkSource:
    """Reads a stream into padded chunks that start with the previous leftover."""

    def __init__(self, stream: BinaryIO, head: bytes, chunk_size: int) -> None:
        self._stream = stream
        self._carry = head
        self._chunk_size = chunk_size
        self.file_offset = 0  # file position of the next chunk's first byte
        self.eof = False

    def next_chunk(self) -> bytearray | None:
        if self.eof and not self._carry:
            return None
        carried = len(self._carry)
        wanted = 0 if self.eof else max(self._chunk_size, 2 * carried)
        # bytearray() is zero-filled, so the padding after the data is zeros.
        buf = bytearray(carried + wanted + PADDING)
        buf[:carried] = self._carry
        got = read_into(self._stream, memoryview(buf)[carried : carried + wanted]) if wanted else 0
        if not got:
            self.eof = True
            if not carried:
                return None
        self._carry = b""
        if got < wanted:
            del buf[carried + got + PADDING :]
        return buf

    def give_back(self, buf: bytearray, consumed: int, size: int) -> None:
        """Keep ``buf[consumed:size]`` for the next chunk."""
        self._carry = bytes(buf[consumed:size])
        self.file_offset += consumed


def read_into(stream: BinaryIO, target: memoryview) -> int:
    """Fill ``target`` from ``stream`` (fewer bytes only at the end of the stream).

    A pipe is read one read at a time (``readinto1``), so a live capture is
    dissected as it arrives rather than after megabytes have accumulated.
    """
    readinto = getattr(stream, "readinto", None)
    seekable = getattr(stream, "seekable", None)
    if seekable is not None and not seekable():
        readinto = getattr(stream, "readinto1", readinto)
    if readinto is not None:
        got = readinto(target)
        return int(got or 0)
    data = stream.read(len(target))
    target[: len(data)] = data
    return len(data)


def entries(parts: list[tuple[np.ndarray, ...]]) -> tuple[np.ndarray, ...]:
    """(start, length, ts_ns, linktype, position) columns of all parts, in file order."""
    columns = list(zip(*parts, strict=True)) if parts else [()] * 5
    arrays = []
    for dtype, column in zip(
        (np.int64, np.int64, np.int64, np.int32, np.int64), columns, strict=True
    ):
        arrays.append(np.concatenate(column).astype(dtype) if column else np.zeros(0, dtype))
    order = np.argsort(arrays[4], kind="stable")
    return tuple(array[order] for array in arrays)
