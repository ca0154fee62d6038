"""fw1394's trace writer against the documented pseudo-header and pcapng block bytes."""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace

VECTOR: dict[str, Any] = json.loads(
    (Path(__file__).parent.parent / "vectors" / "capture_pseudo_header.json").read_text()
)


def test_the_vector_is_its_derivation() -> None:
    header = bytes.fromhex(VECTOR["pseudo_header_hex"])
    record = VECTOR["record"]
    fields = struct.unpack(">BBBBHBBBBH", header)
    assert fields == (1, 12, 0, record["speed"], 0x000B, record["ack"], record["generation"],
                      record["sender"], 0xFF, 0)  # fmt: skip
    block = bytes.fromhex(VECTOR["enhanced_packet_block_hex"])
    data = header + bytes.fromhex(record["packet_hex"])
    ts = record["timestamp_ns"]
    assert block == struct.pack(
        "<IIIIIII", 6, 60, 0, ts >> 32, ts & 0xFFFFFFFF, len(data), len(data)
    ) + data + struct.pack("<I", 60)


def test_the_writer_emits_the_documented_block(tmp_path: Path) -> None:
    record = VECTOR["record"]
    path = tmp_path / "one.pcapng"
    written = BusRecord(
        record["timestamp_ns"], RecordType.async_packet, bytes.fromhex(record["packet_hex"]),
        record["generation"], record["sender"], record["speed"], ack=record["ack"],
    )  # fmt: skip
    assert write_trace(str(path), [written]) == 1
    content = path.read_bytes()
    block = bytes.fromhex(VECTOR["enhanced_packet_block_hex"])
    assert content.endswith(block)
    assert content.count(bytes.fromhex(VECTOR["pseudo_header_hex"])) == 1
