"""The numpy decoder against the codec: same fields, same verdicts on CRCs and lengths."""

from __future__ import annotations

import random
import struct

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.capture.analysis.columns import Problem, decode
from fw1394.capture.analysis.crcvec import crc_of_blocks, crc_of_columns
from fw1394.capture.formats import batch as batches
from fw1394.capture.formats.batch import quadlet_view
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.crc import crc32
from fw1394.packets import LAYOUTS, AsyncPacket, PacketError
from fw1394.packets import decode as codec_decode

KERNEL = {"destination_id", "source_id"}


def random_packet(rng: random.Random) -> bytes:
    """A packet of a random layout: sound, with a bad CRC, truncated or padded."""
    tcode = rng.choice(list(LAYOUTS))
    layout = LAYOUTS[tcode]
    values = {name: rng.getrandbits(layout.header.widths[name]) for name in layout.header.names}
    values["tcode"] = int(tcode)
    if layout.has_data:
        values["data_length"] = rng.choice([0, 1, 4, 7, 16, 64])
    header = layout.header.pack(values)
    raw = header + struct.pack(">I", crc32(header))
    if layout.has_data:
        data = bytes(rng.getrandbits(8) for _ in range(values["data_length"]))
        data += bytes(-len(data) % 4)
        raw += data + struct.pack(">I", crc32(data))
    damage = rng.random()
    if damage < 0.15:
        spot = rng.randrange(len(raw))
        raw = raw[:spot] + bytes([raw[spot] ^ 0x10]) + raw[spot + 1 :]
    elif damage < 0.25:
        raw = raw[: rng.randrange(4, len(raw))]
    elif damage < 0.3:
        raw += b"\x00" * 4
    return raw


def wire_data_crc_bad(raw: bytes, packet: AsyncPacket) -> bool:
    """The data CRC verdict over the quadlets as sent, padding bytes included.

    (The codec checks the data with zero padding; a receiver checks what came.)
    """
    layout = packet.LAYOUT
    if not layout.has_data:
        return False
    start = layout.header_size + 4
    padded = (packet.data_length + 3) & ~3  # type: ignore[attr-defined]
    if len(raw) < start + padded + 4:
        return False
    stored = struct.unpack_from(">I", raw, start + padded)[0]
    return bool(crc32(raw[start : start + padded]) != stored)


def check(raws: list[bytes]) -> None:
    records = [BusRecord(i, RecordType.async_packet, raw) for i, raw in enumerate(raws)]
    batch = batches.from_records(records, list(range(len(raws))))
    decoded = decode(batch, verify_crc=True)
    for row, raw in enumerate(raws):
        try:
            packet = codec_decode(raw, strict=False, kind="async")
        except PacketError:
            assert decoded.problems[row] & (Problem.truncated | Problem.unknown_tcode)
            continue
        assert isinstance(packet, AsyncPacket)
        assert decoded.tcode[row] == packet.tcode
        for name, value in packet.header_fields().items():
            assert decoded.fields[name][row] == value, (name, raw.hex())
        problems = {p.field for p in packet.problems}
        bits = int(decoded.problems[row])
        assert bool(bits & Problem.header_crc) == ("header_crc" in problems), raw.hex()
        assert bool(bits & Problem.data_crc) == wire_data_crc_bad(raw, packet), raw.hex()
        cut = "data" in problems or any("missing" in str(p) for p in packet.problems)
        assert bool(bits & Problem.data_short) == cut, raw.hex()


def test_many_random_packets_decode_like_the_codec() -> None:
    rng = random.Random(1394)
    check([random_packet(rng) for _ in range(3000)])


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_random_packets_decode_like_the_codec(seed: int) -> None:
    rng = random.Random(seed)
    check([random_packet(rng) for _ in range(20)])


def test_vectorised_crc_matches_the_reference() -> None:
    rng = np.random.default_rng(5)
    blocks = [rng.integers(0, 256, 4 * n, dtype=np.uint8).tobytes() for n in (0, 1, 2, 9, 300)]
    buf = np.frombuffer(b"".join(blocks) + bytes(64), np.uint8)
    starts = np.cumsum([0] + [len(b) for b in blocks[:-1]])
    counts = np.array([len(b) // 4 for b in blocks])
    wanted = [crc32(b) for b in blocks]
    assert crc_of_blocks(buf, starts, counts, quadlet_view(buf)).tolist() == wanted
    shifted = np.frombuffer(b"\x00" + buf.tobytes(), np.uint8)
    assert crc_of_blocks(shifted, starts + 1, counts).tolist() == wanted
    quads = np.frombuffer(rng.integers(0, 256, 40, dtype=np.uint8).tobytes(), ">u4")
    quads = quads.astype(np.uint32).reshape(2, 5)
    expected = [
        crc32(quads[0, :3].astype(">u4").tobytes()),
        crc32(quads[1].astype(">u4").tobytes()),
    ]
    assert crc_of_columns(quads, np.array([3, 5])).tolist() == expected


def test_trusted_crc_verdicts_are_rechecked_only_where_they_say_bad() -> None:
    from fw1394.capture.analysis.traffic_sim import simulate
    from fw1394.capture.formats import containers
    from fw1394.capture.formats.trace_writer import record_bytes

    records = list(simulate(200))
    # Corrupt one packet but keep a pseudo-header that claims its CRC is fine.
    victim = next(i for i, r in enumerate(records) if r.record_type == RecordType.async_packet)
    blob = bytearray(record_bytes(records[victim]))
    blob[-1] ^= 0xFF
    import io

    from fw1394.capture.formats.pcap_writer import PcapngWriter

    stream = io.BytesIO()
    writer = PcapngWriter(stream, 147)
    for index, record in enumerate(records):
        writer.write(record.timestamp_ns, bytes(blob) if index == victim else record_bytes(record))
    stream.seek(0)
    (chunk,) = containers.read_chunks(stream)
    batch = batches.from_fw1394_chunk(chunk)
    trusting, checking = decode(batch), decode(batch, verify_crc=True)
    assert not trusting.problems[victim] & (Problem.header_crc | Problem.data_crc)
    assert checking.problems[victim] & (Problem.header_crc | Problem.data_crc)
