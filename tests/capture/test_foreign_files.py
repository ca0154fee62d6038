"""Trace files written by other tools than fw1394, read by fw1394's readers.

pcap and pcapng files are made by Wireshark's own ``text2pcap``, converted by
``editcap`` and joined by ``mergecap`` from hex dumps of the pseudo-header
layout written here from ``docs/capture-format.md``; nosy-dump files are
written by a few lines of ``struct`` from the record layout of Linux's
``tools/firewire/nosy-dump.c`` (the facts as
the spec of capture formats gives them: a host-order C int byte count, then
host-order 32-bit words: microseconds within the second, the wire quadlets,
the snoop ack word). fw1394's own writer's files go the other way, through
``capinfos`` and ``tshark``.
"""

from __future__ import annotations

import itertools
import os
import shutil
import struct
import subprocess
from dataclasses import dataclass
from pathlib import Path

import pytest
from spec_crc import crc32_1394

from fw1394.capture.formats import sources
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace

WIRESHARK_TOOLS = ("text2pcap", "editcap", "mergecap", "capinfos", "tshark")
needs_wireshark = pytest.mark.skipif(
    any(shutil.which(tool) is None for tool in WIRESHARK_TOOLS),
    reason="needs Wireshark's tools (apt-get install tshark wireshark-common)",
)
LINKTYPE_USER0 = 147
ASYNC, ACK, PHY, RESET = 0, 1, 2, 3  # pseudo-header record types
CRC_PRESENT, CRC_VALID, ACK_PRESENT = 0x1, 0x2, 0x8


def with_crc(quadlets: bytes) -> bytes:
    return quadlets + struct.pack(">I", crc32_1394(quadlets))


@dataclass(frozen=True)
class Known:
    """One record as the pseudo-header documents it, and what a reader must give."""

    seconds: int
    micros: int
    record_type: int
    packet: bytes
    generation: int
    sender: int
    ack: int | None = None

    def pseudo_header(self) -> bytes:
        flags = (CRC_PRESENT | CRC_VALID) if self.record_type in (ASYNC, PHY) else 0
        flags |= ACK_PRESENT if self.ack is not None else 0
        return struct.pack(
            ">BBBBHBBBBH", 1, 12, self.record_type, 2, flags, self.ack or 0,
            self.generation, self.sender, 0xFF, 0,
        )  # fmt: skip

    @property
    def timestamp_ns(self) -> int:
        return self.seconds * 1_000_000_000 + self.micros * 1000


BASE = 1_700_000_000  # 2023-11-14 22:13:20 UTC
READ = with_crc(bytes.fromhex("ffc00c40 ffc1ffff f0000400"))  # docs/capture-format.md example
BLOCK = with_crc(bytes.fromhex("ffc10d50 ffc00000 00000000 0000000c 00000000")) + with_crc(
    bytes.fromhex("04040404 0000a000 0c0f7f00")
)  # a 12-byte block read response from 0 to 1
SELF_ID = bytes.fromhex("807f8cc0 7f80733f")  # node 0's self-ID and its inverse
KNOWN = [
    Known(BASE, 123_456, ASYNC, READ, 5, 1, ack=2),
    Known(BASE, 123_490, ASYNC, BLOCK, 5, 0, ack=1),
    Known(BASE + 1, 7, RESET, b"", 6, 0xFF),
    Known(BASE + 1, 40, PHY, SELF_ID, 6, 0),
]


def hexdump(records: list[Known]) -> str:
    """text2pcap input: a date line, then the bytes as an offset-and-hex dump."""
    lines = []
    for known in records:
        stamp = f"2023-11-14 22:13:{20 + known.seconds - BASE:02d}.{known.micros:06d}"
        lines.append(stamp)
        data = known.pseudo_header() + known.packet
        for offset in range(0, len(data), 16):
            chunk = " ".join(f"{b:02x}" for b in data[offset : offset + 16])
            lines.append(f"{offset:06x}  {chunk}")
    return "\n".join(lines) + "\n"


def run(*argv: str) -> str:
    env = {**os.environ, "TZ": "UTC"}
    done = subprocess.run(argv, capture_output=True, text=True, env=env, timeout=60)
    assert done.returncode == 0, f"{argv[0]}: {done.stderr}"
    return done.stdout


def text2pcap(tmp_path: Path, records: list[Known], name: str, *options: str) -> Path:
    dump = tmp_path / f"{name}.txt"
    dump.write_text(hexdump(records))
    out = tmp_path / name
    run("text2pcap", "-q", "-l", str(LINKTYPE_USER0), "-t", "%Y-%m-%d %H:%M:%S.%f",
        *options, str(dump), str(out))  # fmt: skip
    return out


def read_all(path: Path) -> list[tuple[int, BusRecord]]:
    fmt = sources.detect(str(path))
    found = []
    for job in sources.jobs(str(path), fmt):
        batch = job()
        found += [(int(batch.ts_ns[i]), batch.record(i)) for i in range(len(batch))]
    return found


def assert_reads_as(path: Path, expected: list[Known]) -> None:
    got = read_all(path)
    assert len(got) == len(expected), got
    types = {
        ASYNC: RecordType.async_packet,
        PHY: RecordType.phy_packet,
        RESET: RecordType.bus_reset,
    }
    for (timestamp, record), known in zip(got, expected, strict=True):
        assert timestamp == known.timestamp_ns
        assert record.record_type == types[known.record_type]
        assert record.data == known.packet
        assert record.generation == known.generation
        if known.record_type != RESET:
            assert record.sender == known.sender
        assert record.ack == known.ack


@pytest.mark.process
@needs_wireshark
@pytest.mark.parametrize("container", ["pcapng", "pcap"])
def test_text2pcap_files_read_back(tmp_path: Path, container: str) -> None:
    options = () if container == "pcapng" else ("-F", "pcap")
    path = text2pcap(tmp_path, KNOWN, f"t.{container}", *options)
    assert sources.detect(str(path)) == "fw1394"
    assert_reads_as(path, KNOWN)


@pytest.mark.process
@needs_wireshark
@pytest.mark.parametrize("target", ["pcap", "nsecpcap", "pcapng"])
def test_editcap_conversions_read_back(tmp_path: Path, target: str) -> None:
    source = text2pcap(tmp_path, KNOWN, "t.pcapng")
    converted = tmp_path / f"converted.{target}"
    run("editcap", "-F", target, str(source), str(converted))
    assert_reads_as(converted, KNOWN)


@pytest.mark.process
@needs_wireshark
def test_editcap_time_shift_and_mergecap_order(tmp_path: Path) -> None:
    early = text2pcap(tmp_path, KNOWN[:2], "early.pcap", "-F", "pcap")
    late = text2pcap(tmp_path, KNOWN[2:], "late.pcapng")
    shifted = tmp_path / "shifted.pcapng"
    run("editcap", "-t", "-1", str(late), str(shifted))  # one second earlier
    merged = tmp_path / "merged.pcapng"
    run("mergecap", "-w", str(merged), str(shifted), str(early))
    moved = [Known(k.seconds - 1, k.micros, k.record_type, k.packet, k.generation, k.sender,
                   k.ack) for k in KNOWN[2:]]  # fmt: skip
    # The shifted bus reset now comes first: mergecap orders by time.
    expected = sorted(KNOWN[:2] + moved, key=lambda k: k.timestamp_ns)
    assert expected[0].record_type == RESET
    assert_reads_as(merged, expected)


def fw1394_records() -> list[BusRecord]:
    return [
        BusRecord(k.timestamp_ns, RecordType(k.record_type), k.packet, k.generation,
                  None if k.sender == 0xFF else k.sender, ack=k.ack)
        for k in KNOWN
    ]  # fmt: skip


@pytest.mark.process
@needs_wireshark
@pytest.mark.parametrize("container", ["pcapng", "pcap"])
def test_fw1394_files_pass_wireshark_tools(tmp_path: Path, container: str) -> None:
    path = tmp_path / f"ours.{container}"
    write_trace(str(path), fw1394_records(), container=container)
    info = run("capinfos", "-M", str(path))
    assert "USER 0" in info
    assert f"Number of packets:   {len(KNOWN)}" in info
    assert "nanoseconds" in info
    epochs = run("tshark", "-r", str(path), "-T", "fields", "-e", "frame.time_epoch").split()
    assert [round(float(e) * 1e6) for e in epochs] == [k.timestamp_ns // 1000 for k in KNOWN]
    lengths = run("tshark", "-r", str(path), "-T", "fields", "-e", "frame.len").split()
    assert [int(n) for n in lengths] == [12 + len(k.packet) for k in KNOWN]
    # The bytes Wireshark sees are the documented pseudo-header and packet.
    again = tmp_path / "again.pcapng"
    run("editcap", "-F", "pcapng", str(path), str(again))
    assert_reads_as(again, KNOWN)


# -- nosy-dump --------------------------------------------------------------------------


def nosy_record(words: list[int]) -> bytes:
    """One nosy-dump record on a little-endian host: int byte count, host-order words."""
    return struct.pack(f"<i{len(words)}I", 4 * len(words), *words)


def quadlets(data: bytes) -> list[int]:
    return list(struct.unpack(f">{len(data) // 4}I", data))


def test_independently_written_nosy_dump_reads_back(tmp_path: Path) -> None:
    snoop_ack = 0x1230  # the PCILynx status word: the ack code in its low four bits
    dump = b"".join(
        [
            nosy_record([999_990, *quadlets(READ), snoop_ack | 2]),
            nosy_record([999_995, *quadlets(BLOCK), snoop_ack | 1]),
            nosy_record([12]),  # a bus reset: the timestamp alone (the second wrapped)
            nosy_record([30, *quadlets(SELF_ID), 0]),
        ]
    )
    path = tmp_path / "independent.nosy"
    path.write_bytes(dump)
    assert sources.detect(str(path)) == "nosy"
    got = read_all(path)
    kinds = [record.record_type for _, record in got]
    assert kinds == [
        RecordType.async_packet,
        RecordType.async_packet,
        RecordType.bus_reset,
        RecordType.phy_packet,
    ]
    assert got[0][1].data == READ and got[0][1].ack == 2
    assert got[1][1].data == BLOCK and got[1][1].ack == 1
    assert got[3][1].data == SELF_ID
    # Microseconds within the second, unwrapped: 12 us is 17 us after 999,995.
    times = [timestamp for timestamp, _ in got]
    assert [b - a for a, b in itertools.pairwise(times)] == [5_000, 17_000, 18_000]
