"""pcapng interface options read at their documented offsets (draft-ietf-opsawg-pcapng:
each option is code u16, length u16, value padded to 32 bits; if_tsresol is code 9
with one byte, if_tsoffset code 14 with a signed 64-bit count of seconds added to
every timestamp of the interface). The file is written here with ``struct`` alone."""

from __future__ import annotations

import struct
from pathlib import Path

from fw1394.capture.formats import sources


def block(kind: int, body: bytes) -> bytes:
    return struct.pack("<II", kind, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))


def option(code: int, value: bytes) -> bytes:
    return struct.pack("<HH", code, len(value)) + value + bytes(-len(value) % 4)


def test_a_time_offset_after_a_resolution_option_moves_every_timestamp(tmp_path: Path) -> None:
    shb = block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    offset_seconds = 1_000
    options = option(9, bytes([9])) + option(14, struct.pack("<q", offset_seconds)) + option(0, b"")
    idb = block(1, struct.pack("<HHI", 147, 0, 0) + options)
    # docs/capture-format.md: the 12-byte pseudo-header, then its example read request.
    pseudo = struct.pack(">BBBBHBBBBH", 1, 12, 0, 2, 0x3, 0, 5, 1, 0xFF, 0)
    packet = pseudo + bytes.fromhex("ffc00c40ffc1fffff000040011ab9b77")
    nanos = 1_700_000_000_123_456_789
    stamp = struct.pack("<III", 0, nanos >> 32, nanos & 0xFFFFFFFF)
    epb = block(6, stamp + struct.pack("<II", len(packet), len(packet)) + packet)
    path = tmp_path / "offset.pcapng"
    path.write_bytes(shb + idb + epb)
    fmt = sources.detect(str(path))
    (batch,) = [job() for job in sources.jobs(str(path), fmt)]
    assert [int(t) for t in batch.ts_ns] == [nanos + offset_seconds * 1_000_000_000]
    assert batch.packet(0) == packet[12:]


def test_a_binary_time_resolution_counts_powers_of_two(tmp_path: Path) -> None:
    # if_tsresol with its top bit set: units of 2**-(low seven bits) seconds.
    shb = block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    idb = block(1, struct.pack("<HHI", 147, 0, 0) + option(9, bytes([0x80 | 10])) + option(0, b""))
    pseudo = struct.pack(">BBBBHBBBBH", 1, 12, 0, 2, 0x3, 0, 5, 1, 0xFF, 0)
    packet = pseudo + bytes.fromhex("ffc00c40ffc1fffff000040011ab9b77")
    ticks = 3 * 1024 + 512  # 3.5 s in 1/1024 s units
    stamp = struct.pack("<III", 0, ticks >> 32, ticks & 0xFFFFFFFF)
    epb = block(6, stamp + struct.pack("<II", len(packet), len(packet)) + packet)
    path = tmp_path / "binary.pcapng"
    path.write_bytes(shb + idb + epb)
    (batch,) = [job() for job in sources.jobs(str(path), sources.detect(str(path)))]
    assert [int(t) for t in batch.ts_ns] == [3_500_000_000]
