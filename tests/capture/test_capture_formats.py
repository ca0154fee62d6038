"""Trace containers: pcapng and pcap written and read back, damaged files, nosy files."""

from __future__ import annotations

import io
import struct
from pathlib import Path

import numpy as np
import pytest

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import containers, nosy, pseudo_header, sources
from fw1394.capture.formats.pcap_writer import LINKTYPE_ETHERNET, PcapngWriter, PcapWriter
from fw1394.capture.formats.record import BusRecord, Direction, RecordType
from fw1394.capture.formats.trace_writer import crc_ok, write_trace
from fw1394.packets import QuadletReadRequest, encode

RECORDS = list(simulate(400, Scenario(separate_acks=True)))


def read_records(path: Path) -> list[BusRecord]:
    found: list[BusRecord] = []
    with open(path, "rb") as stream:
        for chunk in containers.read_chunks(stream, chunk_size=4096):
            batch = batches.from_fw1394_chunk(chunk)
            found.extend(batch.record(i) for i in range(len(batch)))
    return found


@pytest.mark.parametrize("container", ["pcapng", "pcap"])
def test_records_survive_a_round_trip(tmp_path: Path, container: str) -> None:
    path = tmp_path / f"trace.{container}"
    assert write_trace(str(path), RECORDS, container) == len(RECORDS)
    assert read_records(path) == RECORDS


def test_pseudo_header_round_trip_keeps_every_field() -> None:
    record = BusRecord(
        5,
        RecordType.async_packet,
        encode(QuadletReadRequest(tlabel=3)),
        generation=200,
        sender=7,
        speed=3,
        ack=2,
        crc_present=True,
        direction=Direction.outbound,
        observer=9,
        crc_placeholder=False,
        partial=True,
        time_known=False,
    )
    raw = pseudo_header.encode(record, crc_ok(record))
    assert len(raw) == pseudo_header.HEADER_LENGTH == 12
    header = pseudo_header.decode(raw)
    assert pseudo_header.to_record(header, record.data, 5) == record
    assert header.flag("crc_valid") == 1


def test_pseudo_header_bytes_match_the_documentation() -> None:
    record = BusRecord(0, RecordType.phy_packet, b"", generation=4, sender=1, speed=0, ack=None)
    raw = pseudo_header.encode(record, crc_valid=False)
    # version, length, record type, speed, flags (crc_present), ack, generation, sender,
    # observer (none), reserved
    assert raw.hex() == "010c020000010004" + "01ff0000"


def test_nanosecond_timestamps_and_interface_resolution(tmp_path: Path) -> None:
    path = tmp_path / "t.pcapng"
    with PcapngWriter(open(path, "wb"), LINKTYPE_ETHERNET) as writer:
        writer.write(1_234_567_890_123_456_789, b"\x00" * 20)
    with open(path, "rb") as stream:
        (chunk,) = containers.read_chunks(stream)
    assert chunk.ts_ns.tolist() == [1_234_567_890_123_456_789]
    assert chunk.linktype.tolist() == [LINKTYPE_ETHERNET]


def test_big_endian_pcap_and_microsecond_timestamps(tmp_path: Path) -> None:
    path = tmp_path / "be.pcap"
    body = struct.pack(">IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
    body += struct.pack(">IIII", 10, 500, 4, 4) + b"abcd"
    path.write_bytes(body)
    with open(path, "rb") as stream:
        (chunk,) = containers.read_chunks(stream)
    assert chunk.ts_ns.tolist() == [10_000_500_000]
    assert chunk.packet(0) == b"abcd"


def test_damaged_pcapng_reports_the_position_and_continues(tmp_path: Path) -> None:
    path = tmp_path / "good.pcapng"
    write_trace(str(path), RECORDS[:50])
    data = bytearray(path.read_bytes())
    # Break the length of one block in the middle, and cut the last block short.
    with open(path, "rb") as stream:
        (chunk,) = containers.read_chunks(stream)
    victim = int(chunk.position[20])
    data[victim + 4 : victim + 8] = struct.pack("<I", 0xFFFFFFF0)
    broken = tmp_path / "broken.pcapng"
    broken.write_bytes(bytes(data[:-10]))
    with open(broken, "rb") as stream:
        chunks = list(containers.read_chunks(stream))
    issues = [issue for chunk in chunks for issue in chunk.issues]
    recovered = sum(len(chunk) for chunk in chunks)
    assert any(issue.position == victim for issue in issues)
    assert any("truncated" in issue.message for issue in issues)
    assert 45 <= recovered < 50


def test_damaged_pcap_resynchronises(tmp_path: Path) -> None:
    path = tmp_path / "good.pcap"
    write_trace(str(path), RECORDS[:30], "pcap")
    data = bytearray(path.read_bytes())
    data[24 + 8 : 24 + 12] = struct.pack("<I", 0x7FFFFFFF)  # first record's length
    path.write_bytes(bytes(data))
    with open(path, "rb") as stream:
        chunks = list(containers.read_chunks(stream))
    assert chunks[0].issues[0].position == 24
    assert sum(len(chunk) for chunk in chunks) >= 25


def test_many_chunks_give_the_same_records_as_one(tmp_path: Path) -> None:
    path = tmp_path / "t.pcapng"
    write_trace(str(path), RECORDS)
    with open(path, "rb") as stream:
        small = [c for c in containers.read_chunks(stream, chunk_size=256)]
    assert sum(len(c) for c in small) == len(RECORDS)
    frames = np.concatenate([c.first_frame + np.arange(len(c)) for c in small])
    assert frames.tolist() == list(range(1, len(RECORDS) + 1))


def test_classic_pcap_writer_uses_nanoseconds() -> None:
    stream = io.BytesIO()
    writer = PcapWriter(stream, 147)
    writer.write(3_000_000_007, b"x")
    header = stream.getvalue()
    assert struct.unpack_from("<I", header)[0] == 0xA1B23C4D
    assert struct.unpack_from("<II", header, 24) == (3, 7)


def test_nosy_files_round_trip(tmp_path: Path) -> None:
    path = tmp_path / "dump.nosy"
    wanted = list(simulate(120))
    with open(path, "wb") as stream:
        assert nosy.write(stream, wanted) == len(wanted)
    assert sources.detect(str(path)) == "nosy"
    with open(path, "rb") as stream:
        (batch,) = list(nosy.read_batches(stream))
    assert len(batch) == len(wanted)
    for index, record in enumerate(wanted):
        got = batch.record(index)
        assert got.record_type == record.record_type
        assert got.data == record.data
        if record.record_type == RecordType.async_packet:
            assert got.ack == record.ack
    # Microseconds within the second, unwrapped into a growing time line.
    assert (np.diff(batch.ts_ns) >= 0).all()


def test_nosy_reader_survives_a_bad_length(tmp_path: Path) -> None:
    path = tmp_path / "bad.nosy"
    path.write_bytes(
        struct.pack("<i", 8) + b"\x01\x00\x00\x00" + b"\xff" * 4 + struct.pack("<i", -5)
    )
    with open(path, "rb") as stream:
        (batch,) = list(nosy.read_batches(stream))
    assert batch.issues and "implausible" in batch.issues[-1].message


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"\x0a\x0d\x0d\x0a", "udp"),
        (b"[  1.0] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 2\n", "kernel"),
    ],
)
def test_detect(tmp_path: Path, content: bytes, expected: str) -> None:
    path = tmp_path / "f"
    path.write_bytes(content)
    assert sources.detect(str(path)) == expected


def test_detect_refuses_what_it_cannot_read(tmp_path: Path) -> None:
    for content in (b"", b"hello world\n" * 10, bytes(range(256)) * 4):
        path = tmp_path / "f"
        path.write_bytes(content)
        with pytest.raises(sources.SourceError):
            sources.detect(str(path))
