"""Capture readers and the trace writer at the edges the common files never reach.

Every file and line here is written from its format's documentation, not by
fw1394's writer: pcapng blocks (including the obsolete Packet Block, type 2) and
classic pcap records from the libpcap file-format description, firewire
tracepoint lines as ``include/trace/events/firewire.h`` prints them, Eth1394
datagrams from the JHU layout (request = control word + packet, response =
packet + 8 extra bytes), and the pseudo-header's flags from
``docs/capture-format.md``.
"""

from __future__ import annotations

import io
import struct
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import TextIO, cast

from spec_crc import crc32_1394 as _crc32_1394

from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import containers, kernel, kernel_trace, nosy, sources
from fw1394.capture.formats import eth1394_udp as udp
from fw1394.capture.formats.live import Limits
from fw1394.capture.formats.record import BusRecord, Direction, RecordType
from fw1394.capture.formats.trace_writer import record_bytes

# -- pcapng: the obsolete Packet Block among Enhanced Packet Blocks ---------------------------


def _pad(data: bytes) -> bytes:
    return data + bytes(-len(data) % 4)


def _pcapng_block(block_type: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack("<II", block_type, length) + body + struct.pack("<I", length)


def _enhanced(stamp: int, data: bytes) -> bytes:
    head = struct.pack("<IIIII", 0, stamp >> 32, stamp & 0xFFFFFFFF, len(data), len(data))
    return _pcapng_block(6, head + _pad(data))


def _obsolete(stamp: int, data: bytes, original: int) -> bytes:
    # Interface ID and drops count are 16 bits each in the obsolete Packet Block.
    head = struct.pack("<HHIIII", 0, 0, stamp >> 32, stamp & 0xFFFFFFFF, len(data), original)
    return _pcapng_block(2, head + _pad(data))


def test_obsolete_packet_blocks_keep_their_file_position_and_order_across_chunks() -> None:
    section = _pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    interface = _pcapng_block(1, struct.pack("<HHI", 147, 0, 0))  # no if_tsresol: microseconds
    packets = [
        ("epb", 1_000, bytes(range(4))),
        ("pb", 2_000, bytes(range(10, 22))),
        ("epb", 3_000, bytes(range(30, 35))),
        ("pb", 4_000, bytes(range(40, 48))),
        ("pb", 5_000, bytes(range(50, 51))),
    ]
    content, expected = section + interface, []
    for kind, stamp, data in packets:
        expected.append((len(content), stamp * 1_000, data))
        content += _enhanced(stamp, data) if kind == "epb" else _obsolete(stamp, data, 1500)
    # Chunks far smaller than the file: most blocks lie in chunks that start past byte 0.
    found = []
    for chunk in containers.read_chunks(io.BytesIO(content), chunk_size=48):
        assert chunk.issues == []
        found += [
            (int(chunk.position[i]), int(chunk.ts_ns[i]), chunk.packet(i))
            for i in range(len(chunk))
        ]
    assert found == expected


# -- classic pcap: resynchronising after a damaged record header ------------------------------


def _pcap_record(seconds: int, micros: int, data: bytes, original: int) -> bytes:
    return struct.pack("<IIII", seconds, micros, len(data), original) + data


def test_pcap_resynchronises_on_long_and_snapped_records_running_to_the_end() -> None:
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147)
    first = _pcap_record(1_700_000_000, 1, b"\x11" * 12, 12)
    # A record header whose captured length is beyond the snapshot length: damage.
    damage = b"\xff" * 16
    long = _pcap_record(1_700_000_000, 2, bytes(range(256)) + bytes(44), 300)  # 300 of 300 bytes
    snapped = _pcap_record(1_700_000_000, 3, b"\x22" * 60, 1000)  # 60 of 1000 bytes kept
    content = header + first + damage + long + snapped
    chunks = list(containers.read_chunks(io.BytesIO(content)))
    positions = [int(p) for chunk in chunks for p in chunk.position]
    data = [chunk.packet(i) for chunk in chunks for i in range(len(chunk))]
    issues = [issue for chunk in chunks for issue in chunk.issues]
    at = len(header)
    assert positions == [at, at + len(first) + 16, at + len(first) + 16 + len(long)]
    assert data == [b"\x11" * 12, long[16:], b"\x22" * 60]
    assert [issue.position for issue in issues] == [at + len(first)]
    assert "implausible" in issues[0].message


# -- Eth1394 UDP: a payload both readings accept ----------------------------------------------


def test_a_response_that_also_reads_as_a_request_is_told_by_its_size() -> None:
    # Quadlet read response (tcode 6) from node 0x0005 (bus 0, physical ID 5) to 0xFFD0,
    # tl 7, data 'QLA1', zero CRC as the FPGA's Ethernet path sends, then 8 extra bytes.
    response = struct.pack(">5I", 0xFFD01C60, 0x00050000, 0, 0x514C4131, 0)
    payload = response + bytes.fromhex("10050000006400c8")
    # Read as a request, the bytes after the 2-byte control word start with tcode 0
    # (the low byte of the source ID): a quadlet write request, 26 bytes for its 20.
    assert payload[2 + 3] >> 4 == 0
    assert udp.classify(payload) == "response"
    # Neither reading adds up (the response is cut short): the request reading wins.
    cut = payload[:16] + payload[-8:]
    assert udp.classify(cut) == "request"


# -- kernel text: only outbound initiates wait for their completion ---------------------------


_INBOUND = (
    "<idle>-0 [002] d.h2. 2107.432895: async_request_inbound: "
    "transaction=0xffff8ee1c9a07f00 card_index=0 generation=3 scode=2 status=2 timestamp=0x3c62 "
    "dst_id=0xffc1 tlabel=10 tcode=4 src_id=0xffc0 offset=0xfffff0000200 "
    "header={0xffc12940,0xffc0ffff,0xf0000200,0x0} data={}\n"
)
_RESPONSE = (
    "kworker/2:3-125 [002] ..... 2107.432907: async_response_outbound_initiate: "
    "transaction=0xffff8ee1c9a07f00 card_index=0 generation=3 scode=2 dst_id=0xffc0 tlabel=10 "
    "tcode=6 src_id=0xffc1 rcode=0 header={0xffc02960,0xffc10000,0x0,0x105c2a} data={}\n"
)
_COMPLETE = (
    "<idle>-0 [002] d.h2. 2107.432916: async_response_outbound_complete: "
    "transaction=0xffff8ee1c9a07f00 card_index=0 generation=3 scode=2 status=1 timestamp=0x3c6c\n"
)


def test_an_inbound_request_is_delivered_at_its_own_line_and_the_response_waits_for_its_ack() -> (
    None
):
    taken: list[str] = []

    def lines() -> Iterator[str]:  # kernel text that counts the lines taken from it
        for line in (_INBOUND, _RESPONSE, _COMPLETE):
            taken.append(line)
            yield line

    batches = kernel.KernelTextReader(cast(TextIO, lines())).batches(batch_records=1)
    first = next(batches)
    # The inbound request carries its ack (status=2, ack_pending) on its own line and
    # shares its transaction with the response: it must not wait for that response.
    assert len(taken) == 1
    (request,) = [first.record(i) for i in range(len(first))]
    assert request.direction == Direction.inbound and request.ack == 2
    assert request.observer == 1  # an inbound packet is logged by its destination, 0xffc1
    assert request.data[3] >> 4 == 4  # tcode 4: quadlet read request
    second = next(batches)
    assert len(taken) == 3  # the response came out with its completion line
    (response,) = [second.record(i) for i in range(len(second))]
    assert response.direction == Direction.outbound and response.ack == 1  # ack_complete
    assert response.observer == 1  # an outbound one by its source, 0xffc1
    assert response.data[3] >> 4 == 6
    assert list(batches) == []


# -- the trace writer: a PHY packet's check quadlet -------------------------------------------

_CRC_PRESENT, _CRC_VALID = 0x0001, 0x0002  # docs/capture-format.md, flags word at offset 4


def _phy_flags(quadlet: int, check: int) -> tuple[int, int]:
    record = BusRecord(1_000, RecordType.phy_packet, struct.pack(">II", quadlet, check))
    written = record_bytes(record)
    assert written[12:] == struct.pack(">II", quadlet, check)
    record_type, _, flags = struct.unpack_from(">BBH", written, 2)
    return record_type, flags & (_CRC_PRESENT | _CRC_VALID)


def test_a_phy_packet_with_its_inverse_is_written_as_checked_and_sound() -> None:
    # A PHY configuration packet (root 1, gap count 63) and its bitwise inverse.
    assert _phy_flags(0x01BF0000, 0xFE40FFFF) == (2, _CRC_PRESENT | _CRC_VALID)
    assert _phy_flags(0x01BF0000, 0xFE40FFFE) == (2, _CRC_PRESENT)
    assert _phy_flags(0x01BF0000, 0x01BF0000) == (2, _CRC_PRESENT)


def test_a_block_response_that_also_reads_as_a_request_is_told_by_its_padded_size() -> None:
    # Block read response (tcode 7) from node 0x0005 with 5 data bytes: 16 header bytes,
    # header CRC, the data padded to 8, data CRC (32 bytes), then 8 extra bytes.
    head = struct.pack(">4I", 0xFFD01C70, 0x00050000, 0, 5 << 16)
    response = head + bytes(4) + b"QLA1\x07" + bytes(3) + bytes(4)
    payload = response + bytes.fromhex("10050000006400c8")
    assert udp.classify(payload) == "response"


# -- captured Ethernet frames: addresses and link types ---------------------------------------


def _udp(payload: bytes) -> bytes:
    return struct.pack(">HHHH", 1394, 1394, 8 + len(payload), 0) + payload


def _ipv4(source: bytes, destination: bytes, payload: bytes) -> bytes:
    header = struct.pack(">BBHHHBBH", 0x45, 0, 20 + len(payload), 0, 0, 64, 17, 0)
    return header + source + destination + payload


def test_the_datagrams_addresses_come_from_the_ip_header() -> None:
    datagram = _udp(b"\x00\x05" + bytes(16))
    ethernet = (
        bytes(6)
        + bytes(6)
        + b"\x08\x00"
        + _ipv4(bytes([10, 0, 0, 1]), bytes([10, 0, 0, 2]), datagram)
    )
    found = udp.udp_payload(1, ethernet)  # LINKTYPE_ETHERNET
    assert isinstance(found, udp.Datagram)
    assert (found.source, found.destination) == ("10.0.0.1", "10.0.0.2")
    assert found.payload == b"\x00\x05" + bytes(16)
    # IPv6 (LINKTYPE_RAW, 101): version 6, payload length, next header 17 (UDP), hop limit,
    # then the 16-byte source and destination addresses.
    source, destination = bytes(range(16)), bytes(range(16, 32))
    ipv6 = struct.pack(">IHBB", 6 << 28, len(datagram), 17, 64) + source + destination
    found = udp.udp_payload(101, ipv6 + datagram)
    assert isinstance(found, udp.Datagram)
    assert (found.source, found.destination) == (source.hex(), destination.hex())


def test_linux_cooked_v2_frames_are_read_at_link_type_276() -> None:
    # LINKTYPE_LINUX_SLL2 (276): protocol type(2) reserved(2) interface index(4)
    # ARPHRD type(2) packet type(1) address length(1) address(8), then the IP packet.
    cooked = struct.pack(">HHIHBB8s", 0x0800, 0, 2, 1, 0, 6, bytes(8))
    frame = cooked + _ipv4(
        bytes([10, 0, 0, 1]), bytes([10, 0, 0, 2]), _udp(b"\x00\x05" + bytes(16))
    )
    found = udp.udp_payload(276, frame)
    assert isinstance(found, udp.Datagram) and found.source == "10.0.0.1"


# -- pcap: resynchronisation needs three records in a row, not every record to the end -----------


def test_pcap_resynchronises_before_a_second_damaged_record() -> None:
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147)
    good = [_pcap_record(1_700_000_000, i, bytes([i]) * 8, 8) for i in range(5)]
    damage = b"\xff" * 16
    content = header + good[0] + damage + good[1] + good[2] + good[3] + damage + good[4]
    chunks = list(containers.read_chunks(io.BytesIO(content)))
    data = [chunk.packet(i) for chunk in chunks for i in range(len(chunk))]
    assert data == [bytes([i]) * 8 for i in range(5)]
    assert len([issue for chunk in chunks for issue in chunk.issues]) == 2


# -- fw1394 pcapng: a pseudo-header of another version is not read as this one ------------------


def test_a_record_with_an_unknown_pseudo_header_version_is_an_issue(tmp_path: Path) -> None:
    section = _pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))
    interface = _pcapng_block(1, struct.pack("<HHI", 147, 0, 0))  # LINKTYPE_USER0
    packet = struct.pack(">4I", 0xFFC00C40, 0xFFC1FFFF, 0xF0000400, 0)  # a quadlet read
    # docs/capture-format.md: version, header_length 12, record_type 0 (async packet),
    # speed, flags, ack, generation, sender, observer, reserved.
    # flags 0x0008: ack_present, with ack 2 (ack_pending); the good record's header is 16
    # bytes long (readers skip header_length bytes, so 4 more bytes are allowed).
    blocks = []
    for version, size in ((1, 16), (2, 12)):
        head = struct.pack(">BBBBHBBBBH", version, size, 0, 2, 8, 2, 5, 1, 0xFF, 0)
        blocks.append(_enhanced(1, head + bytes(size - 12) + packet))
    path = tmp_path / "versions.pcapng"
    path.write_bytes(section + interface + b"".join(blocks))
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    assert len(batch) == 1 and batch.record(0).data == packet
    assert (batch.record(0).ack, batch.record(0).generation, batch.record(0).sender) == (2, 5, 1)
    assert [issue.position for issue in batch.issues] == [len(section + interface + blocks[0])]


# -- nosy-dump: each bus reset starts a generation ---------------------------------------------


def test_each_bus_reset_in_a_nosy_dump_starts_the_next_generation(tmp_path: Path) -> None:
    # Records: a C int byte count (little-endian host), then host-order words; a bus reset
    # is the timestamp alone; a PHY packet is the quadlet, its inverse and the snoop ack.
    def record(*words: int) -> bytes:
        return struct.pack(f"<i{len(words)}I", 4 * len(words), *words)

    phy = 0x01BF0000
    dump = record(10, phy, phy ^ 0xFFFFFFFF, 0) + record(20) + record(30) + record(40)
    dump += record(50, phy, phy ^ 0xFFFFFFFF, 0)
    path = tmp_path / "resets.nosy"
    path.write_bytes(dump)
    found = [batch.record(i) for job in sources.jobs(str(path), "nosy") for batch in [job()]
             for i in range(len(batch))]  # fmt: skip
    assert [r.record_type for r in found] == [RecordType.phy_packet] + [
        RecordType.bus_reset
    ] * 3 + [RecordType.phy_packet]
    assert [r.generation for r in found] == [0, 1, 2, 3, 3]


# -- live capture limits --------------------------------------------------------------------------


def test_a_capture_ends_on_a_stop_request_or_its_packet_count() -> None:
    stop = threading.Event()
    assert not Limits(stop).done(1_000_000)
    assert not Limits(stop, count=3).done(2) and Limits(stop, count=3).done(3)
    stop.set()
    assert Limits(stop).done(0)


def test_a_block_packet_is_written_as_sound_only_when_both_crcs_match() -> None:
    # Block write request (tcode 1), 5 data bytes padded to 8; header CRC, data CRC.
    header = struct.pack(">4I", 0xFFC00410, 0xFFC1FFFF, 0xF0000400, 5 << 16)
    data = b"QLA1\x07" + bytes(3)

    def flags(packet: bytes) -> int:
        written = record_bytes(BusRecord(1_000, RecordType.async_packet, packet))
        return int(struct.unpack_from(">H", written, 4)[0]) & (_CRC_PRESENT | _CRC_VALID)

    sound = header + struct.pack(">I", _crc32_1394(header)) + data
    assert flags(sound + struct.pack(">I", _crc32_1394(data))) == _CRC_PRESENT | _CRC_VALID
    assert flags(sound + struct.pack(">I", _crc32_1394(data) ^ 1)) == _CRC_PRESENT


# -- pcapng: simple packet blocks, several interfaces, a damaged block, a clean end ---------------


def _section() -> bytes:
    return _pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))


def _interface(linktype: int) -> bytes:
    return _pcapng_block(1, struct.pack("<HHI", linktype, 0, 0))


def _simple(data: bytes) -> bytes:
    return _pcapng_block(3, struct.pack("<I", len(data)) + _pad(data))


def _read(content: bytes, chunk_size: int) -> tuple[list[tuple[int, int, bytes]], list[int]]:
    packets, issues = [], []
    for chunk in containers.read_chunks(io.BytesIO(content), chunk_size=chunk_size):
        issues += [issue.position for issue in chunk.issues]
        packets += [
            (int(chunk.position[i]), int(chunk.linktype[i]), chunk.packet(i))
            for i in range(len(chunk))
        ]
    return packets, issues


def test_simple_packet_blocks_need_an_interface_and_keep_their_position() -> None:
    # A block of a type the reader does not know is skipped; it pushes what follows
    # into later chunks.
    content = _section() + _pcapng_block(0x0BAD, bytes(100))
    early = len(content)
    content += _simple(b"\x01\x02\x03") + _interface(147)  # the first one has no interface
    expected = []
    for index in range(8):
        data = bytes([index]) * (5 + 3 * index)
        expected.append((len(content), 147, data))
        content += _simple(data)
    for chunk_size in (40, 56, 1 << 20):
        assert _read(content, chunk_size) == (expected, [early])


def test_a_big_endian_section_after_a_little_endian_one_is_read_to_its_end() -> None:
    little = _section() + _interface(147) + _enhanced(1, b"\x01" * 4)
    # The same blocks in big-endian order: the byte-order magic tells the reader.
    big = struct.pack(">IIIHHqI", 0x0A0D0D0A, 28, 0x1A2B3C4D, 1, 0, -1, 28)
    big += struct.pack(">IIHHII", 1, 20, 147, 0, 0, 20)
    for index in range(8):  # more than 256 bytes
        body = struct.pack(">IIIII", 0, 0, index, 20, 20) + bytes([index]) * 20
        big += struct.pack(">II", 6, 12 + len(body)) + body + struct.pack(">I", 12 + len(body))
    packets, issues = _read(little + big, chunk_size=1 << 20)
    assert [data for _, _, data in packets] == [b"\x01" * 4] + [bytes([i]) * 20 for i in range(8)]
    assert issues == []


def test_enhanced_packet_blocks_take_the_link_type_of_their_interface() -> None:
    content = _section() + _interface(147) + _interface(1)
    expected = []
    for index in range(6):
        block = struct.pack("<IIIII", index % 2, 0, index, 4, 4) + bytes([index]) * 4
        expected.append((len(content), (147, 1)[index % 2], bytes([index]) * 4))
        content += _pcapng_block(6, block)
    assert _read(content, chunk_size=1 << 20) == (expected, [])


def test_reading_resumes_at_the_next_packet_block_after_a_bad_block_length() -> None:
    content = _section() + _interface(147) + _enhanced(1, b"\x01" * 4)
    damaged = len(content)
    content += struct.pack("<II", 0x0BAD, 13) + bytes(8)  # length 13: not a multiple of 4
    after = len(content)
    content += _enhanced(2, b"\x02" * 4) + _enhanced(3, b"\x03" * 4)
    packets, issues = _read(content, chunk_size=1 << 20)
    assert [data for _, _, data in packets] == [b"\x01" * 4, b"\x02" * 4, b"\x03" * 4]
    assert packets[1][0] == after and issues == [damaged]


def test_a_file_ending_on_a_block_boundary_has_no_truncated_block() -> None:
    content = _section() + _interface(147)
    content += b"".join(_enhanced(i, bytes(40)) for i in range(10))  # over 256 bytes
    packets, issues = _read(content, chunk_size=1 << 20)
    assert len(packets) == 10 and issues == []


def test_ipv6_over_ethernet_is_read() -> None:
    datagram = _udp(b"\x00\x05" + bytes(16))
    source, destination = bytes(range(16)), bytes(range(16, 32))
    ipv6 = struct.pack(">IHBB", 6 << 28, len(datagram), 17, 64) + source + destination
    found = udp.udp_payload(1, bytes(12) + b"\x86\xdd" + ipv6 + datagram)
    assert isinstance(found, udp.Datagram) and found.source == source.hex()


def test_ports_of_refused_datagrams_are_counted_busiest_first() -> None:
    tally = sources.PortTally((1394,))
    assert 1394 in tally
    for port in (7000, 6000, 5000, 5000, 6000, 5000):  # first seen is not busiest
        assert port not in tally
    assert tally.busiest() == [5000, 6000, 7000]
    assert tally.busiest(1) == [5000]


def test_nosy_dump_records_carry_microseconds_within_the_second() -> None:
    out = io.BytesIO()
    nosy.write(out, [BusRecord(1_234_567_890, RecordType.bus_reset, b"")])
    assert out.getvalue() == struct.pack("<iI", 4, 234_567)


def test_packets_of_any_size_are_packed_apart_and_read_back() -> None:
    sizes = (1, 5, 4)
    records = [
        BusRecord(i, RecordType.async_packet, bytes([i + 1]) * n) for i, n in enumerate(sizes)
    ]
    batch = batches.from_records(records, [1, 2, 3])
    assert [batch.record(i).data for i in range(3)] == [r.data for r in records]
    # The first quadlets of each packet: only its whole quadlets, zeros after them.
    quadlets = batches.header_quadlets(batch, None, 4)
    assert quadlets.tolist() == [[0, 0, 0, 0], [0x02020202, 0, 0, 0], [0x03030303, 0, 0, 0]]


def test_the_ohci_dmesg_sample_reads_without_issues() -> None:
    path = Path(__file__).parents[1] / "data" / "firewire-ohci-dmesg.txt"
    with open(path, encoding="utf-8") as stream:
        found = list(kernel.read_batches(stream))
    assert [issue for batch in found for issue in batch.issues] == []
    assert sum(len(batch) for batch in found) > 0


# -- fourth round: the remaining fields and limits ---------------------------------------------


def test_an_eth1394_response_is_seen_by_its_destination_and_sent_by_its_source() -> None:
    response = struct.pack(">5I", 0xFFD01C60, 0xFFC00000, 0, 0x514C4131, 0)
    datagram = udp.Datagram(response + bytes.fromhex("10050000006400c8"), "10.0.0.2", "10.0.0.1")
    found = udp.Eth1394Decoder().records(datagram, 1_000)
    assert isinstance(found, list)
    ((record),) = found
    assert (record.sender, record.observer) == (0, 0x10)  # 0xFFC0 sent it, 0xFFD0 logged it


def test_obsolete_packet_blocks_of_no_data_and_of_an_undefined_interface() -> None:
    content = _section() + _pcapng_block(0x0BAD, bytes(100)) + _interface(147)
    empty = len(content)
    content += _obsolete(7, b"", 0)  # 32 bytes: a packet of no bytes
    undefined = len(content)
    head = struct.pack("<HHIIII", 3, 0, 0, 8, 4, 4)  # interface 3 was never described
    content += _pcapng_block(2, head + bytes(4))
    for chunk_size in (40, 1 << 20):
        packets, issues = _read(content, chunk_size)
        assert packets == [(empty, 147, b"")] and issues == [undefined]


def test_timestamps_finer_than_a_nanosecond_are_cut_to_nanoseconds() -> None:
    # if_tsresol (option 9) = 12: picoseconds; then end of options.
    options = struct.pack("<HHB3x", 9, 1, 12) + struct.pack("<HH", 0, 0)
    interface = _pcapng_block(1, struct.pack("<HHI", 147, 0, 0) + options)
    content = _section() + interface + _enhanced(5_000_999, b"\x01" * 4)
    chunks = list(containers.read_chunks(io.BytesIO(content)))
    assert [int(t) for chunk in chunks for t in chunk.ts_ns] == [5_000]


def test_records_without_a_node_read_back_without_one(tmp_path: Path) -> None:
    records = [BusRecord(1, RecordType.bus_reset, b"", 3)]  # no sender, no observer
    assert batches.from_records(records, [1]).record(0).observer is None
    # The pseudo-header's 0xFF (docs/capture-format.md: no such node) reads as None.
    head = struct.pack(">BBBBHBBBBH", 1, 12, 3, 0xFF, 0, 0, 3, 0xFF, 0xFF, 0)
    path = tmp_path / "reset.pcapng"
    path.write_bytes(_section() + _interface(147) + _enhanced(1, head))
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    assert (batch.record(0).sender, batch.record(0).observer) == (None, None)
    assert (int(batch.sender[0]), int(batch.observer[0])) == (-1, -1)  # the columns' "unknown"


def test_a_capture_ends_when_its_duration_has_passed() -> None:
    stop = threading.Event()
    assert not Limits(stop, duration=60.0).done(0)
    assert Limits(stop, duration=0.0).done(0)


def test_a_nosy_head_must_chain_whole_records() -> None:
    reset = struct.pack("<iI", 4, 12)  # a bus reset: the timestamp alone
    assert nosy.plausible(reset * 3)
    assert not nosy.plausible(b"")
    assert not nosy.plausible(reset + struct.pack("<i", -1) + bytes(8))  # a damaged length


# -- fifth round -------------------------------------------------------------------------------


def test_bsd_loopback_frames_carry_the_ip_packet_after_a_4_byte_family() -> None:
    # LINKTYPE_NULL (0): a 4-byte address family in host byte order, then the IP packet.
    ip = _ipv4(bytes([10, 0, 0, 1]), bytes([10, 0, 0, 2]), _udp(b"\x00\x05" + bytes(16)))
    found = udp.udp_payload(0, struct.pack("<I", 2) + ip)
    assert isinstance(found, udp.Datagram) and found.source == "10.0.0.1"


def test_a_nosy_dump_async_packet_is_sent_by_its_source(tmp_path: Path) -> None:
    # A quadlet read request from 0xFFC1 to 0xFFC0 (header CRC not checked here), ack 2.
    words = [0xFFC00140, 0xFFC1FFFF, 0xF0000400, 0x12345678]
    path = tmp_path / "read.nosy"
    path.write_bytes(struct.pack("<i6I", 24, 10, *words, 0x1232))
    (batch,) = [job() for job in sources.jobs(str(path), "nosy")]
    assert (batch.record(0).sender, batch.record(0).ack) == (1, 2)


def test_the_linux_status_for_no_ack_is_a_missing_ack() -> None:
    # include/linux/firewire-constants.h: RCODE_NO_ACK 0x14; other rcodes carry no ack.
    assert kernel_trace.ack_of_status(0x14) == 0
    assert kernel_trace.ack_of_status(0x15) is None
    assert kernel_trace.ack_of_status(0x4) == 4


def test_a_tracepoint_with_generation_0_is_read() -> None:
    line = _INBOUND.replace("generation=3", "generation=0")
    event = kernel_trace.parse(line)
    assert event is not None and event.records[0].generation == 0


def test_fw1394_records_are_numbered_from_the_first_frame(tmp_path: Path) -> None:
    head = struct.pack(">BBBBHBBBBH", 1, 12, 3, 0xFF, 0, 0, 3, 0xFF, 0xFF, 0)
    path = tmp_path / "resets.pcapng"
    path.write_bytes(_section() + _interface(147) + b"".join(_enhanced(i, head) for i in range(4)))
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    assert [int(f) for f in batch.frame] == [1, 2, 3, 4]


def test_an_empty_resolution_option_leaves_microseconds_and_a_long_packet_block_is_an_issue() -> (
    None
):
    # if_tsresol (9) with no value, then end of options: the default, microseconds.
    options = struct.pack("<HH", 9, 0) + struct.pack("<HH", 0, 0)
    interface = _pcapng_block(1, struct.pack("<HHI", 147, 0, 0) + options)
    content = _section() + interface + _enhanced(7, b"\x01" * 4)
    bad = len(content)
    head = struct.pack("<HHIIII", 0, 0, 0, 8, 40, 40)  # 40 bytes said, 4 there
    content += _pcapng_block(2, head + bytes(4))
    chunks = list(containers.read_chunks(io.BytesIO(content), chunk_size=1 << 20))
    assert [int(t) for chunk in chunks for t in chunk.ts_ns] == [7_000]
    assert [issue.position for chunk in chunks for issue in chunk.issues] == [bad]


# -- sixth round -------------------------------------------------------------------------------


def test_a_block_response_of_whole_quadlets_is_not_padded_further() -> None:
    # Block read response with 8 data bytes: 20 header bytes, 8 data, data CRC, 8 extra.
    head = struct.pack(">4I", 0xFFD01C70, 0x00050000, 0, 8 << 16)
    payload = head + bytes(4) + b"QLA1QLA2" + bytes(4) + bytes.fromhex("10050000006400c8")
    assert udp.classify(payload) == "response"


def test_classic_pcap_fw1394_records_of_odd_lengths_read_back(tmp_path: Path) -> None:
    # Classic pcap (microseconds), LINKTYPE_USER0; each record a pseudo-header and an odd
    # number of bytes, so the second record's data starts one byte past a quadlet
    # boundary (offset 49 of the records: 16 + 17 + 16).
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147)
    packets = [bytes([n]) * (4 * n + 1) for n in (1, 2)]
    content = header
    for n, packet in enumerate(packets):
        pseudo = struct.pack(">BBBBHBBBBH", 1, 12, 0, 2, 0, 0, 5, n, 0xFF, 0)
        data = pseudo + packet
        content += struct.pack("<IIII", 1_700_000_000, n, len(data), len(data)) + data
    path = tmp_path / "odd.pcap"
    path.write_bytes(content)
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    assert [batch.record(i).data for i in range(len(batch))] == packets
    assert [batch.record(i).sender for i in range(len(batch))] == [0, 1]


# -- seventh round -------------------------------------------------------------------------------


def test_a_second_section_of_the_same_byte_order_is_read() -> None:
    # The second Section Header Block starts 84 bytes in (4 past a multiple of 8).
    section = _section() + _interface(147) + _enhanced(1, b"\x01" * 4)
    assert len(section) % 8 == 4
    packets, issues = _read(section + section, chunk_size=1 << 20)
    assert [data for _, _, data in packets] == [b"\x01" * 4] * 2 and issues == []


def test_an_obsolete_packet_block_of_40_bytes_is_read_whole() -> None:
    data = bytes(range(40))
    content = _section() + _interface(147) + _obsolete(1, data, 40)
    packets, issues = _read(content, chunk_size=1 << 20)
    assert [p for _, _, p in packets] == [data] and issues == []


def test_a_frame_cut_inside_its_udp_header_carries_no_datagram() -> None:
    ip = _ipv4(bytes([10, 0, 0, 1]), bytes([10, 0, 0, 2]), _udp(b"\x00\x05" + bytes(16)))
    ethernet = bytes(12) + b"\x08\x00" + ip
    assert udp.udp_payload(1, ethernet[: 14 + 20 + 6]) is None


def test_the_flags_of_fw1394_records_are_read_by_name(tmp_path: Path) -> None:
    # docs/capture-format.md flags: crc_present 0x1, crc_valid 0x2, ack_present 0x8,
    # direction in bits 5:4, time_unknown 0x80.
    flags = (0x0001, 0x0008 | 2 << 4, 0x0080)
    blocks = b"".join(
        _enhanced(i, struct.pack(">BBBBHBBBBH", 1, 12, 3, 0xFF, f, 2, 3, 0xFF, 0xFF, 0))
        for i, f in enumerate(flags)
    )
    path = tmp_path / "flags.pcapng"
    path.write_bytes(_section() + _interface(147) + blocks)
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    assert batch.flag("crc_present").tolist() == [1, 0, 0]
    assert batch.flag("direction").tolist() == [0, 2, 0]
    assert batch.flag("time_unknown").tolist() == [0, 0, 1]
