"""pcapng in chunks: Enhanced Packet Blocks found with numpy, the rest walked in Python.

Every pcapng block repeats its length at its end, which makes a cheap and
verifiable guess of where the Enhanced Packet Blocks are: a word equal to 6
whose following length is repeated where the block would end. Only other
blocks, or damaged ones, are walked one at a time.
"""

from __future__ import annotations

import struct
from collections.abc import Iterator
from dataclasses import dataclass
from typing import BinaryIO

import numpy as np

from fw1394.capture.formats.chunks import (
    MAX_RECORD,
    PADDING,
    ChunkSource,
    PacketChunk,
    entries,
)
from fw1394.capture.formats.pcap_writer import (
    BYTE_ORDER_MAGIC,
    EPB_HEADER_SIZE,
    EPB_TYPE,
    IDB_TYPE,
    IF_TSOFFSET,
    IF_TSRESOL,
    PB_TYPE,
    SHB_TYPE,
    SPB_TYPE,
)
from fw1394.capture.formats.read_issues import Issue

_I64 = np.int64


@dataclass
class _Interface:
    linktype: int
    resolution: tuple[int, int] = (10, 6)  # base, exponent: 10**-6 s by default
    offset_s: int = 0


class PcapngReader:
    """Every packet of a pcapng stream, chunk by chunk (sections and interfaces followed)."""

    def __init__(self, stream: BinaryIO, head: bytes, chunk_size: int) -> None:
        self._source = ChunkSource(stream, head, chunk_size)
        self._order = "<"
        self._interfaces: list[_Interface] = []
        self._frame = 1

    def chunks(self) -> Iterator[PacketChunk]:
        source = self._source
        while (buf := source.next_chunk()) is not None:
            size = len(buf) - PADDING
            issues: list[Issue] = []
            parts: list[tuple[np.ndarray, ...]] = []
            consumed = self._parse(buf, size, source.file_offset, parts, issues)
            if source.eof and consumed < size:
                # Whatever is left can never become a block.
                issues.append(
                    Issue(
                        source.file_offset + consumed,
                        f"truncated block ({size - consumed} bytes)",
                        cut_short=True,
                    )
                )
                consumed = size
            source.give_back(buf, consumed, size)
            start, length, ts_ns, linktype, position = entries(parts)
            chunk = PacketChunk(buf, start, length, ts_ns, linktype, position, self._frame, issues)
            self._frame += len(chunk)
            if len(chunk) or issues:
                yield chunk

    # -- one chunk -------------------------------------------------------------------------
    def _parse(
        self,
        buf: bytearray,
        size: int,
        base: int,
        parts: list[tuple[np.ndarray, ...]],
        issues: list[Issue],
    ) -> int:
        pos = 0
        while True:
            words = np.frombuffer(buf, dtype=np.dtype(self._order + "u4"), count=size // 4)
            runs = _EpbRuns(words, size)
            pos, restart = self._walk(buf, size, base, pos, words, runs, parts, issues)
            if not restart:
                return pos

    def _walk(
        self,
        buf: bytearray,
        size: int,
        base: int,
        pos: int,
        words: np.ndarray,
        runs: _EpbRuns,
        parts: list[tuple[np.ndarray, ...]],
        issues: list[Issue],
    ) -> tuple[int, bool]:
        order = self._order
        while size - pos >= 12:
            run = runs.run_at(pos // 4)
            if run is not None:
                first, last = run
                parts.append(self._epb_columns(words, runs.starts[first : last + 1], base, issues))
                pos = int(runs.next[last]) * 4
                continue
            block_type, length = struct.unpack_from(order + "II", buf, pos)
            if block_type == SHB_TYPE:
                if size - pos < 16:
                    return pos, False
                magic = struct.unpack_from("<I", buf, pos + 8)[0]
                new_order = "<" if magic == BYTE_ORDER_MAGIC else ">"
                if new_order != order:
                    self._order = new_order
                    if pos:
                        return pos, False  # finish this chunk; the next one starts here
                    return pos, True
                length = struct.unpack_from(order + "I", buf, pos + 4)[0]
            if length < 12 or length % 4 or length > MAX_RECORD:
                issues.append(Issue(base + pos, f"bad block length {length}; skipping ahead"))
                pos = runs.next_start_after(pos // 4, size) * 4
                continue
            if pos + length > size:
                return pos, False
            trailer = struct.unpack_from(order + "I", buf, pos + length - 4)[0]
            if trailer != length:
                issues.append(Issue(base + pos, f"block length {length} != trailer {trailer}"))
                pos = runs.next_start_after(pos // 4, size) * 4
                continue
            self._block(buf, pos, block_type, length, base, parts, issues)
            pos += length
        return pos, False

    def _epb_columns(
        self, words: np.ndarray, starts: np.ndarray, base: int, issues: list[Issue]
    ) -> tuple[np.ndarray, ...]:
        interface = words[starts + 2].astype(_I64)
        stamp = (words[starts + 3].astype(np.uint64) << np.uint64(32)) | words[starts + 4]
        caplen = words[starts + 5].astype(_I64)
        block_length = words[starts + 1].astype(_I64)
        position = starts.astype(_I64) * 4
        good = (caplen <= block_length - 32) & (interface < len(self._interfaces))
        if not good.all():
            for bad in np.flatnonzero(~good)[:100]:
                issues.append(
                    Issue(base + int(position[bad]), "packet block with a bad length or interface")
                )
            interface, stamp, caplen, position = (
                a[good] for a in (interface, stamp, caplen, position)
            )
        if len(self._interfaces) == 1:
            # The common case: one interface, no per-packet grouping needed.
            only = self._interfaces[0]
            linktype = np.full(len(stamp), only.linktype, np.int32)
            return (
                position + EPB_HEADER_SIZE,
                caplen,
                _to_ns(stamp, only),
                linktype,
                position + base,
            )
        ts_ns = np.zeros(len(stamp), _I64)
        linktype = np.zeros(len(stamp), np.int32)
        for number in np.unique(interface):
            chosen = interface == number
            info = self._interfaces[int(number)]
            ts_ns[chosen] = _to_ns(stamp[chosen], info)
            linktype[chosen] = info.linktype
        return position + EPB_HEADER_SIZE, caplen, ts_ns, linktype, position + base

    def _block(
        self,
        buf: bytearray,
        pos: int,
        block_type: int,
        length: int,
        base: int,
        parts: list[tuple[np.ndarray, ...]],
        issues: list[Issue],
    ) -> None:
        order = self._order
        if block_type == SHB_TYPE:
            self._interfaces = []
        elif block_type == IDB_TYPE and length >= 20:
            linktype = struct.unpack_from(order + "H", buf, pos + 8)[0]
            self._interfaces.append(self._interface(buf, pos + 16, pos + length - 4, linktype))
        elif block_type == PB_TYPE and length >= 32:
            # Enhanced Packet Blocks never come here: every one whose length and trailer
            # agree (the walk checks both first) is a start _EpbRuns found.
            interface, _, high, low, caplen = struct.unpack_from(order + "HHIII", buf, pos + 8)
            if interface >= len(self._interfaces) or caplen > length - 32:
                issues.append(Issue(base + pos, "packet block with a bad length or interface"))
                return
            info = self._interfaces[interface]
            stamp = np.array([(high << 32) | low], np.uint64)
            self._single(
                parts, pos + EPB_HEADER_SIZE, caplen, _to_ns(stamp, info)[0], info, pos + base
            )
        elif block_type == SPB_TYPE and length >= 16:
            if not self._interfaces:
                issues.append(Issue(base + pos, "simple packet block before any interface"))
                return
            original = struct.unpack_from(order + "I", buf, pos + 8)[0]
            caplen = min(original, length - 16)
            self._single(parts, pos + 12, caplen, 0, self._interfaces[0], pos + base)

    @staticmethod
    def _single(
        parts: list[tuple[np.ndarray, ...]],
        start: int,
        caplen: int,
        ts_ns: int,
        info: _Interface,
        position: int,
    ) -> None:
        parts.append(
            (
                np.array([start], _I64),
                np.array([caplen], _I64),
                np.array([ts_ns], _I64),
                np.array([info.linktype], np.int32),
                np.array([position], _I64),
            )
        )

    def _interface(self, buf: bytearray, pos: int, end: int, linktype: int) -> _Interface:
        info = _Interface(linktype)
        order = self._order
        while pos + 4 <= end:
            code, length = struct.unpack_from(order + "HH", buf, pos)
            value = bytes(buf[pos + 4 : pos + 4 + length])
            if code == 0:
                break
            if code == IF_TSRESOL and length >= 1:
                exponent = value[0]
                info.resolution = (2, exponent & 0x7F) if exponent & 0x80 else (10, exponent)
            elif code == IF_TSOFFSET and length >= 8:
                info.offset_s = struct.unpack(order + "q", value[:8])[0]
            pos += 4 + length + (-length % 4)
        return info


def _to_ns(stamp: np.ndarray, info: _Interface) -> np.ndarray:
    base, exponent = info.resolution
    offset = info.offset_s * 1_000_000_000
    if base == 10 and exponent <= 9:
        scaled = stamp.astype(_I64) * _I64(10 ** (9 - exponent))
    elif base == 10 and exponent - 9 < 20:  # 10**19 is the largest power in a uint64
        scaled = (stamp // np.uint64(10 ** (exponent - 9))).astype(_I64)
    elif base == 10:
        scaled = np.zeros(len(stamp), _I64)  # units far below a nanosecond: all round to 0
    else:
        scaled = (stamp.astype(np.float64) * 1e9 / float(1 << exponent)).astype(_I64)
    # A damaged if_tsoffset can exceed what int64 nanoseconds hold: clamp, don't overflow.
    limit = int(np.iinfo(_I64).max)
    return scaled + _I64(max(-limit, min(limit, offset)))


class _EpbRuns:
    """Where the Enhanced Packet Blocks of a chunk are, found without a Python loop.

    A word equal to 6 whose following length is repeated at the block's end is
    a candidate block start. Candidates that chain (each ends where the next
    begins) form runs; a walk from a known block boundary jumps from run to run,
    so a candidate that is really packet data inside a block is never used.
    """

    def __init__(self, words: np.ndarray, size: int) -> None:
        count = len(words)
        candidates = np.flatnonzero(words[: max(count - 1, 0)] == EPB_TYPE)
        lengths = words[candidates + 1].astype(_I64)
        shaped = (lengths % 4 == 0) & (lengths >= 32)
        fits = candidates * 4 + lengths <= size
        ok = shaped & fits
        #: Candidates that run past the chunk's end (or whose length is in the next
        #: chunk): where a skip stops when no whole block follows.
        tail = [count - 1] if count and words[count - 1] == EPB_TYPE else []
        running_on = candidates[shaped & ~fits & (lengths <= MAX_RECORD)]
        self.open_starts = np.concatenate([running_on, tail]).astype(_I64)
        candidates, lengths = candidates[ok], lengths[ok]
        ok = words[candidates + lengths // 4 - 1] == lengths
        self.starts = candidates[ok].astype(_I64)
        self.next = self.starts + lengths[ok] // 4
        chained = np.zeros(len(self.starts), bool)
        if len(self.starts) > 1:
            chained[:-1] = self.starts[1:] == self.next[:-1]
        self._breaks = np.flatnonzero(~chained)

    def run_at(self, word: int) -> tuple[int, int] | None:
        """(first, last) candidate indexes of the chained run starting at ``word``."""
        index = int(np.searchsorted(self.starts, word))
        if index >= len(self.starts) or self.starts[index] != word:
            return None
        last = int(self._breaks[np.searchsorted(self._breaks, index)])
        return index, last

    def next_start_after(self, word: int, size: int) -> int:
        index = int(np.searchsorted(self.starts, word, side="right"))
        if index < len(self.starts):
            return int(self.starts[index])
        # No whole block follows: stop where one may begin that the next chunk completes,
        # rather than drop the chunk's tail with it.
        later = int(np.searchsorted(self.open_starts, word, side="right"))
        return int(self.open_starts[later]) if later < len(self.open_starts) else size // 4
