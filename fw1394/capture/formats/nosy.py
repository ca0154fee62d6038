"""nosy-dump ``--output`` files (Linux tools/firewire, TI PCILynx snoop hardware).

No header and no magic: a sequence of records, each a C ``int`` byte count in
the host's byte order (little-endian on the x86 machines nosy ran on)
followed by that many bytes. The bytes are 32-bit host-order words: a
timestamp in microseconds *within the current second*, then the packet's
wire quadlets (header CRC, data block and data CRC included), then the snoop
ack quadlet whose low four bits are the ack code (0: no ack). A PHY packet is
its quadlet, the inverse and the ack; a bus reset is the timestamp alone.
"""

from __future__ import annotations

import struct
from collections.abc import Iterable, Iterator
from typing import BinaryIO

from fw1394.capture.formats import batch as batches
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.containers import Issue
from fw1394.capture.formats.record import SPEED_UNKNOWN, BusRecord, RecordType
from fw1394.packets.accessors import SOURCE_ID, readers
from fw1394.packets.fields import Quadlets
from fw1394.packets.nodeid import phy_of

#: nosy-dump reads into a 128 Ki-word buffer; a longer record is corruption.
MAX_RECORD = 128 * 1024 * 4
BATCH_RECORDS = 20_000
_LENGTH = struct.Struct("<i")
#: The PCILynx snoop status word after each packet: the ack code in its low bits.
SNOOP_ACK = Quadlets((("status", 28), ("ack", 4)))
_SNOOP_ACK_CODE = readers(SNOOP_ACK)["ack"]


def plausible(head: bytes) -> bool:
    """True if ``head`` starts with a few records that chain like a nosy file."""
    offset, records = 0, 0
    while offset + 4 <= len(head) and records < 8:
        (length,) = _LENGTH.unpack_from(head, offset)
        if length < 0 or length > MAX_RECORD or length % 4:
            return False
        offset += 4 + length
        records += 1
    return records >= 1 and (offset == len(head) or records == 8 or offset > len(head))


def read_batches(stream: BinaryIO, batch_records: int = BATCH_RECORDS) -> Iterator[Batch]:
    """Every record of a nosy file, as batches."""
    reader = _Reader(stream)
    frame = 1
    while True:
        records, positions, issues = reader.take(batch_records)
        if not records and not issues:
            return
        frames = range(frame, frame + len(records))
        frame += len(records)
        yield batches.from_records(records, frames, positions, issues)


class _Reader:
    def __init__(self, stream: BinaryIO) -> None:
        self._stream = stream
        self._offset = 0
        self._second = 0
        self._last_us = -1
        self._last_ns = 0
        self._generation = 0
        self._done = False

    def take(self, count: int) -> tuple[list[BusRecord], list[int], list[Issue]]:
        records: list[BusRecord] = []
        positions: list[int] = []
        issues: list[Issue] = []
        while len(records) < count and not self._done:
            position = self._offset
            head = self._stream.read(4)
            if len(head) < 4:
                if head:
                    issues.append(Issue(position, f"{len(head)} stray bytes at the end"))
                self._done = True
                break
            (length,) = _LENGTH.unpack(head)
            if length < 0 or length > MAX_RECORD:
                issues.append(Issue(position, f"record length {length} is implausible; stopping"))
                self._done = True
                break
            body = self._stream.read(length)
            self._offset += 4 + len(body)
            if len(body) < length:
                message = f"record cut short ({len(body)} of {length} bytes)"
                issues.append(Issue(position, message, cut_short=True))
                self._done = True
                break
            record = self._record(body, position, issues)
            if record is not None:
                records.append(record)
                positions.append(position)
        return records, positions, issues

    def _time(self, microseconds: int) -> int:
        # The timestamp restarts every second; a smaller value means a new second.
        if self._last_us >= 0 and microseconds < self._last_us:
            self._second += 1
        self._last_us = microseconds
        self._last_ns = (self._second * 1_000_000 + microseconds) * 1000
        return self._last_ns

    def _record(self, body: bytes, position: int, issues: list[Issue]) -> BusRecord | None:
        if len(body) < 4:
            self._generation = (self._generation + 1) % 256
            return BusRecord(self._last_ns, RecordType.bus_reset, b"", self._generation)
        words = struct.unpack(f"<{len(body) // 4}I", body[: len(body) & ~3])
        timestamp = self._time(words[0])
        if len(words) == 1:
            self._generation = (self._generation + 1) % 256
            return BusRecord(timestamp, RecordType.bus_reset, b"", self._generation)
        if len(body) % 4:
            issues.append(Issue(position, f"record of {len(body)} bytes is not whole quadlets"))
        if len(words) < 4:
            issues.append(
                Issue(position, "short packet: " + " ".join(f"{w:08x}" for w in words[1:]))
            )
            return None
        quadlets, ack = words[1:-1], _SNOOP_ACK_CODE(words[-1:])
        wire = struct.pack(f">{len(quadlets)}I", *quadlets)
        if len(quadlets) == 2 and quadlets[0] ^ quadlets[1] == 0xFFFFFFFF:
            kind = RecordType.phy_packet
        else:
            kind = RecordType.async_packet
        return BusRecord(
            timestamp,
            kind,
            wire,
            generation=self._generation,
            speed=SPEED_UNKNOWN,
            ack=ack if kind == RecordType.async_packet else None,  # PHY packets are not acked
            sender=phy_of(SOURCE_ID(quadlets)) if kind == RecordType.async_packet else None,
        )


def write(stream: BinaryIO, records: Iterable[BusRecord]) -> int:
    """Write records as nosy-dump would have (for tests and conversions)."""
    written = 0
    for record in records:
        microseconds = (record.timestamp_ns // 1000) % 1_000_000
        if record.record_type == RecordType.bus_reset:
            words: tuple[int, ...] = (microseconds,)
        elif record.record_type == RecordType.ack:
            continue
        else:
            data = record.data + bytes(-len(record.data) % 4)
            quadlets = struct.unpack(f">{len(data) // 4}I", data)
            words = (microseconds, *quadlets, record.ack or 0)
        body = struct.pack(f"<{len(words)}I", *words)
        stream.write(_LENGTH.pack(len(body)) + body)
        written += 1
    return written
