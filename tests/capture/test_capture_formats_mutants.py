"""Trace readers at edges the format tests do not reach.

Files are built here from the pcapng specification (block type, total length,
body, total length again; little-endian in these files), libpcap's classic
header and record layout, Ethernet II / IPv4 (RFC 791) / UDP (RFC 768) headers,
the pseudo-header of docs/capture-format.md (12 bytes, big-endian; direction in
flag bits 5..4: 0 bus, 1 outbound, 2 inbound) and Eth1394 datagrams of
jhu-eth1394.md §1.6.
"""

from __future__ import annotations

import io
import struct
from pathlib import Path

import pytest

from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import containers, kernel, kernel_trace, nosy, sources
from fw1394.capture.formats import eth1394_udp as udp
from fw1394.capture.formats.chunks import read_into
from fw1394.capture.formats.pseudo_header import decode as decode_pseudo_header
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import record_bytes


def pcapng_block(block_type: int, body: bytes) -> bytes:
    length = 12 + len(body)
    return struct.pack("<II", block_type, length) + body + struct.pack("<I", length)


def section() -> bytes:
    return pcapng_block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1))


def interface(linktype: int) -> bytes:
    return pcapng_block(1, struct.pack("<HHI", linktype, 0, 0))


def enhanced(interface_id: int, stamp: int, data: bytes) -> bytes:
    head = struct.pack(
        "<IIIII", interface_id, stamp >> 32, stamp & 0xFFFFFFFF, len(data), len(data)
    )
    return pcapng_block(6, head + data + bytes(-len(data) % 4))


def read(content: bytes, chunk_size: int) -> tuple[list[tuple[int, int, bytes]], list[int]]:
    """(file position, link type, bytes) of each packet, and the positions of issues."""
    packets, issues = [], []
    for chunk in containers.read_chunks(io.BytesIO(content), chunk_size=chunk_size):
        issues += [issue.position for issue in chunk.issues]
        packets += [
            (int(chunk.position[i]), int(chunk.linktype[i]), chunk.packet(i))
            for i in range(len(chunk))
        ]
    return packets, issues


def test_the_direction_of_a_record_is_named_and_a_reserved_one_numbered() -> None:
    names = [batches.direction_name(value) for value in range(4)]
    assert names == ["bus", "outbound", "inbound", "reserved_3"]


@pytest.mark.parametrize("chunk_size", [64, 100, 1 << 20])
def test_packets_of_two_interfaces_keep_their_file_positions_in_any_chunking(
    chunk_size: int,
) -> None:
    content = section() + interface(147) + interface(1)
    expected = []
    for index in range(6):
        expected.append((len(content), (147, 1)[index % 2], bytes([index]) * 4))
        content += enhanced(index % 2, index, bytes([index]) * 4)
    assert read(content, chunk_size) == (expected, [])


def test_a_pseudo_header_of_another_version_is_refused_by_its_version() -> None:
    raw = struct.pack(">BBBBHBBBBH", 2, 12, 0, 2, 0, 0, 5, 1, 0xFF, 0)
    with pytest.raises(ValueError, match=r"^pseudo-header version 2 is not 1$"):
        decode_pseudo_header(raw)


def test_records_without_ack_sender_or_observer_are_columns_of_minus_one(tmp_path: Path) -> None:
    # As a reader of files gives them (test_records_without_a_node_read_back_without_one).
    record = BusRecord(1, RecordType.bus_reset, b"", 3)
    batch = batches.from_records([record], [1])
    assert (int(batch.ack[0]), int(batch.sender[0]), int(batch.observer[0])) == (-1, -1, -1)
    assert batch.record(0) == record


def eth1394_frame(payload: bytes) -> bytes:
    udp = struct.pack(">HHHH", 40000, 1394, 8 + len(payload), 0) + payload
    ip = struct.pack(
        ">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), 0, 0, 64, 17, 0, bytes([127, 0, 0, 1]),
        bytes([127, 0, 0, 2]),
    )  # fmt: skip
    return bytes(12) + b"\x08\x00" + ip + udp


def test_eth1394_records_are_numbered_by_their_frames(tmp_path: Path) -> None:
    # Three quadlet reads (jhu-eth1394.md §1.6), one per Ethernet frame, in classic pcap.
    reads = [
        "0105ffc01c40ffd0000000000004a9927b79",
        "0105ffc02840ffd0000000000000c0518b0f",
        "0007ffc13040ffd0000000000004127ae411",
    ]
    content = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
    for number, text in enumerate(reads):
        frame = eth1394_frame(bytes.fromhex(text))
        content += struct.pack("<IIII", 1_700_000_000, number, len(frame), len(frame)) + frame
    path = tmp_path / "reads.pcap"
    path.write_bytes(content)
    found = [job() for job in sources.jobs(str(path), "udp")]
    frames = [int(f) for batch in found for f in batch.frame]
    kinds = [int(k) for batch in found for k in batch.record_type]
    # Bus resets come first where the control word's generation moves (5, then 0 and 7).
    assert [f for f, k in zip(frames, kinds, strict=True) if k == 0] == [1, 2, 3]


class Trickle(io.RawIOBase):
    """A pipe: ten bytes at a time, and no seeking."""

    def __init__(self) -> None:
        self.left = 100

    def readable(self) -> bool:
        return True

    def readinto(self, buffer: memoryview) -> int:  # type: ignore[override]
        count = min(10, self.left, len(buffer))
        buffer[:count] = bytes(count)
        self.left -= count
        return count


def test_a_pipe_is_read_as_it_comes_and_a_file_in_full() -> None:
    target = memoryview(bytearray(100))
    assert read_into(io.BufferedReader(Trickle(), buffer_size=10), target) == 10
    assert read_into(io.BytesIO(bytes(100)), target) == 100


def test_header_quadlets_of_packets_off_a_quadlet_boundary(tmp_path: Path) -> None:
    # Classic pcap records of a pseudo-header and 5 and 9 bytes: the second packet
    # starts one byte past a quadlet boundary in the file.
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147)
    packets = [bytes(range(1, 6)), bytes(range(11, 20))]
    content = header
    for n, packet in enumerate(packets):
        data = struct.pack(">BBBBHBBBBH", 1, 12, 0, 2, 0, 0, 5, n, 0xFF, 0) + packet
        content += struct.pack("<IIII", 1_700_000_000, n, len(data), len(data)) + data
    path = tmp_path / "odd.pcap"
    path.write_bytes(content)
    (batch,) = [job() for job in sources.jobs(str(path), "fw1394")]
    quadlets = batches.header_quadlets(batch, None, 2)
    assert quadlets.tolist() == [
        [0x01020304, 0],  # the second quadlet lies past the 5-byte packet
        [0x0B0C0D0E, 0x0F101112],
    ]


def test_a_packet_block_claiming_more_bytes_than_it_holds_is_an_issue() -> None:
    # Total length 64 leaves 32 bytes of packet; a captured length of 40 runs into the
    # block's trailer. The blocks around it read as usual.
    good = enhanced(0, 1, b"\x11" * 8)
    body = struct.pack("<IIIII", 0, 0, 2, 40, 40) + b"\x22" * 32
    liar = pcapng_block(6, body)
    assert len(liar) == 64
    head = section() + interface(147)
    content = head + good + liar + good
    packets, issues = read(content, 1 << 20)
    assert [(position, data) for position, _, data in packets] == [
        (len(head), b"\x11" * 8),
        (len(head) + len(good) + 64, b"\x11" * 8),
    ]
    assert issues == [len(head) + len(good)]


# Linux firewire tracepoints (include/trace/events/firewire.h) as the kernel prints them:
# an outbound response waits for its completion line, which carries its ack
# (status=1: ack_complete); an unrelated inbound request is logged in between.
_RESPONSE = (
    "kworker/2:3-125 [002] ..... 2107.432907: async_response_outbound_initiate: "
    "transaction=0xffff8ee1c9a07f00 card_index=0 generation=3 scode=2 dst_id=0xffc0 tlabel=10 "
    "tcode=6 src_id=0xffc1 rcode=0 header={0xffc02960,0xffc10000,0x0,0x105c2a} data={}\n"
)
_OTHER_INBOUND = (
    "<idle>-0 [002] d.h2. 2107.432910: async_request_inbound: "
    "transaction=0xffff8ee1c9a08000 card_index=0 generation=3 scode=2 status=2 timestamp=0x3c63 "
    "dst_id=0xffc1 tlabel=11 tcode=4 src_id=0xffc0 offset=0xfffff0000204 "
    "header={0xffc12d40,0xffc0ffff,0xf0000204,0x0} data={}\n"
)
_COMPLETE = (
    "<idle>-0 [002] d.h2. 2107.432916: async_response_outbound_complete: "
    "transaction=0xffff8ee1c9a07f00 card_index=0 generation=3 scode=2 status=1 timestamp=0x3c6c\n"
)


def test_a_waiting_response_is_not_passed_by_a_later_ready_record() -> None:
    reader = kernel.KernelTextReader(io.StringIO(_RESPONSE + _OTHER_INBOUND + _COMPLETE))
    records = [batch.record(i) for batch in reader.batches() for i in range(len(batch))]
    assert [(r.data[3] & 0xF0, r.ack) for r in records] == [(0x60, 1), (0x40, 2)]


def classic_pcap(linktype: int, records: list[bytes], snaplen: int = 65535) -> bytes:
    content = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, snaplen, linktype)
    for number, data in enumerate(records):
        content += struct.pack("<IIII", 1_700_000_000, number, len(data), len(data)) + data
    return content


def test_a_record_longer_than_16_mib_is_implausible_whatever_the_snap_length() -> None:
    # A snap length of 0xFFFFFFFF (some writers' "no limit") does not make a 32 MiB
    # record plausible: it is an issue, and reading goes on at the next record.
    first, last = bytes([1]) * 8, bytes([3]) * 8
    content = classic_pcap(1, [first], snaplen=0xFFFFFFFF)
    damaged = len(content)
    content += struct.pack("<IIII", 1_700_000_000, 1, 32 << 20, 32 << 20)
    content += struct.pack("<IIII", 1_700_000_000, 2, len(last), len(last)) + last
    packets, issues = read(content, 1 << 20)
    assert [data for _, _, data in packets] == [first, last]
    assert issues == [damaged]


def test_a_nosy_dump_of_one_record_is_recognised() -> None:
    # A bus reset alone: its length (4, little-endian) and the timestamp.
    assert nosy.plausible(struct.pack("<iI", 4, 123_456))
    assert not nosy.plausible(struct.pack("<iI", 5, 123_456) + b"\0")


def test_linux_cooked_frames_are_read_at_link_type_113(tmp_path: Path) -> None:
    # Linux cooked capture v1: packet type, ARPHRD type, address length, 8 address
    # bytes, protocol (0x0800 IPv4); then the IP packet.
    read_request = bytes.fromhex("0105ffc01c40ffd0000000000004a9927b79")
    ip_packet = eth1394_frame(read_request)[14:]
    cooked = struct.pack(">HHH8sH", 4, 1, 6, bytes(8), 0x0800) + ip_packet
    path = tmp_path / "cooked.pcap"
    path.write_bytes(classic_pcap(113, [cooked]))
    found = [job() for job in sources.jobs(str(path), "udp")]
    records = [batch.record(i) for batch in found for i in range(len(batch))]
    assert [r.data for r in records if r.record_type == RecordType.async_packet] == [
        bytes.fromhex("ffc01c40ffd0000000000004a9927b79")
    ]


def test_an_obsolete_packet_block_keeps_a_timestamp_past_32_bits() -> None:
    stamp = 1_700_000_000_123_456  # microseconds: the high word is not zero
    data = b"\x44" * 4
    body = struct.pack("<HHIIII", 0, 0, stamp >> 32, stamp & 0xFFFFFFFF, 4, 4) + data
    content = section() + interface(147) + pcapng_block(2, body)
    (chunk,) = containers.read_chunks(io.BytesIO(content), chunk_size=1 << 20)
    assert int(chunk.ts_ns[0]) == stamp * 1000


@pytest.mark.parametrize(
    "bad",
    [
        struct.pack("<II", 0x99, 14) + bytes(8),  # not a whole number of quadlets
        struct.pack("<IIII", 0x99, 16, 0, 20),  # its trailer says another length
    ],
    ids=["length", "trailer"],
)
def test_a_block_of_a_bad_length_is_skipped_to_the_next_packet_block(bad: bytes) -> None:
    head = section() + interface(147)
    good = enhanced(0, 7, b"\x55" * 4)
    content = head + bad + good
    packets, issues = read(content, 1 << 20)
    assert [(position, data) for position, _, data in packets] == [(len(head) + 16, b"\x55" * 4)]
    assert issues == [len(head)]


def test_a_firewire_ohci_block_read_line_gives_its_length_and_time() -> None:
    # tests/data/firewire-ohci-dmesg.txt, line 15: a block read request of 0x58 bytes.
    line = (
        "[  431.207282] firewire_ohci 0000:05:00.0: AT spd 2 tl 0f, ffc1 -> ffc0, ack_pending ,"
        " BR req, fffff0000414 58,0\n"
    )
    (batch,) = list(kernel.read_batches(io.StringIO(line)))
    record = batch.record(0)
    assert record.timestamp_ns == 431_207_282_000
    quadlets = struct.unpack(">4I", record.data[:16])
    assert quadlets[3] >> 16 == 0x58 and quadlets[0] >> 10 & 0x3F == 0x0F


def test_an_empty_block_before_the_interface_does_not_hide_its_link_type() -> None:
    # pcapng allows a block of 12 bytes (type, length, length): a reader skips it.
    empty = struct.pack("<III", 0x99, 12, 12)
    assert sources.detect_head(section() + empty + interface(147), "empty.pcapng") == "fw1394"
    assert sources.detect_head(section() + empty + interface(1), "empty.pcapng") == "udp"


def test_nosy_dump_records_are_numbered_from_frame_1(tmp_path: Path) -> None:
    # Three bus resets: each record a little-endian length of 4 and the timestamp.
    path = tmp_path / "resets.nosy"
    path.write_bytes(b"".join(struct.pack("<iI", 4, 1000 * n) for n in range(3)))
    (batch,) = [job() for job in sources.jobs(str(path), "nosy")]
    assert [int(f) for f in batch.frame] == [1, 2, 3]


def test_a_firewire_ohci_phy_line_gives_the_quadlet_and_its_inverse() -> None:
    # tests/data/firewire-ohci-dmesg.txt, line 8.
    line = "[  431.206331] firewire_ohci 0000:05:00.0: AT ack_complete, PHY 01bf0000 fe40ffff\n"
    (batch,) = list(kernel.read_batches(io.StringIO(line)))
    record = batch.record(0)
    assert record.record_type == RecordType.phy_packet
    assert record.data == bytes.fromhex("01bf0000fe40ffff")


def test_a_pcap_header_cut_short_names_no_link_type() -> None:
    head = struct.pack("<IHH", 0xA1B2C3D4, 2, 4)  # 8 of the header's 24 bytes
    assert sources.detect_head(head, "short.pcap") == "udp"


def test_kernel_times_reach_the_largest_signed_64_bit_nanosecond() -> None:
    # 2**63 - 1 ns = 9223372036.854775807 s: the last time a record can hold.
    assert kernel_trace.nanoseconds("9223372036", "854775807") == 2**63 - 1
    assert kernel_trace.nanoseconds("5000000000", "5") == 5_000_000_000_500_000_000
    with pytest.raises(kernel_trace.TraceLineError):
        kernel_trace.nanoseconds("9223372036", "854775808")


def test_header_quadlets_past_a_short_packets_end_are_zero_not_the_next_packet() -> None:
    short = BusRecord(1, RecordType.async_packet, bytes.fromhex("ffc00c40ffc1ffff00000004"), 5)
    after = BusRecord(2, RecordType.async_packet, b"\xee" * 20, 5)
    batch = batches.from_records([short, after], [1, 2])
    quadlets = batches.header_quadlets(batch, None, 5).tolist()
    assert quadlets[0] == [0xFFC00C40, 0xFFC1FFFF, 4, 0, 0]
    assert quadlets[1] == [0xEEEEEEEE] * 5


def test_frames_too_short_for_their_headers_are_other_traffic_and_unknown_links_a_problem() -> None:
    ethernet = bytes(12) + b"\x08\x00"
    assert udp.udp_payload(1, ethernet[:10]) is None  # not even an Ethernet header
    assert udp.udp_payload(1, ethernet + b"\x45\x00\x00\x1c\x00") is None  # IPv4 cut short
    assert udp.udp_payload(1, ethernet + b"\x45" + bytes(18)) is None  # one byte short
    assert udp.udp_payload(999, bytes(40)) == "unsupported link type 999"


def test_records_keep_the_positions_they_are_given() -> None:
    records = [BusRecord(n, RecordType.bus_reset, b"", n) for n in range(3)]
    batch = batches.from_records(records, [1, 2, 3], [100, 228, 356])
    assert [int(p) for p in batch.position] == [100, 228, 356]
    assert [int(f) for f in batch.frame] == [1, 2, 3]


def test_only_ip_ethertypes_carry_datagrams() -> None:
    # An ARP frame (0x0806) whose bytes would read as an IPv6 UDP datagram to port 1394.
    ipv6_like = bytearray(48)
    ipv6_like[6] = 17  # "next header: UDP"
    ipv6_like[40:44] = struct.pack(">HH", 40000, 1394)
    assert udp.udp_payload(1, bytes(12) + b"\x08\x06" + bytes(ipv6_like)) is None
    assert udp.udp_payload(1, bytes(12) + b"\x86\xdd" + bytes(ipv6_like)) is not None


def test_interface_options_without_an_end_marker_are_read_to_the_trailer() -> None:
    # if_tsresol (9) = 9, nanoseconds, as the last option, with no opt_endofopt after it.
    idb = pcapng_block(1, struct.pack("<HHI", 147, 0, 0) + struct.pack("<HHB3x", 9, 1, 9))
    content = section() + idb + enhanced(0, 1_700_000_000_123_456_789, b"\x01" * 4)
    (chunk,) = containers.read_chunks(io.BytesIO(content), chunk_size=1 << 20)
    assert int(chunk.ts_ns[0]) == 1_700_000_000_123_456_789


def test_a_pcap_file_of_its_header_alone_is_detected_by_its_link_type() -> None:
    header = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 147)
    assert sources.detect_head(header, "empty.pcap") == "fw1394"


def test_a_nosy_dump_packet_of_whole_quadlets_reads_without_issues(tmp_path: Path) -> None:
    words = [0xFFC00140, 0xFFC1FFFF, 0xF0000400, 0x12345678]
    path = tmp_path / "read.nosy"
    path.write_bytes(struct.pack("<i6I", 24, 10, *words, 0x1232))
    (batch,) = [job() for job in sources.jobs(str(path), "nosy")]
    assert len(batch) == 1 and batch.issues == []


def test_a_self_id_sequence_alone_gives_self_ids_and_no_bus_reset() -> None:
    # tests/data/firewire-tracepoints.txt, line 15, in a generation no bus reset listed.
    line = (
        "kworker/1:2-97 [001] ..... 2107.431052: self_id_sequence: card_index=0 generation=3"
        " phy_id=0x00 link_active=true gap_count=63 scode=2 contender=false power_class=4"
        " initiated_reset=false port_status={0x2,0x1,0x1} self_id_sequence={0x807f8494}\n"
    )
    (batch,) = list(kernel.read_batches(io.StringIO(line)))
    assert batch.issues == []
    assert [batch.record(i).record_type for i in range(len(batch))] == [RecordType.phy_packet]
    assert batch.record(0).data[:4] == bytes.fromhex("807f8494")


def test_a_file_cut_inside_a_block_says_how_many_bytes_are_left() -> None:
    content = section() + interface(147) + enhanced(0, 1, b"\x01" * 4)[:20]
    packets, _ = read(content, 1 << 20)
    issues = [
        (issue.position, issue.message)
        for chunk in containers.read_chunks(io.BytesIO(content), chunk_size=1 << 20)
        for issue in chunk.issues
    ]
    assert packets == [] and issues == [(len(content) - 20, "truncated block (20 bytes)")]


@pytest.mark.parametrize("chunk_size", range(40, 144, 4))
def test_blocks_after_a_bad_one_are_read_whatever_the_chunks(chunk_size: int) -> None:
    # A skip past damage stops at a packet block that the next chunk completes, rather
    # than at the chunk's end.
    head = section() + interface(147)
    bad = struct.pack("<II", 0x99, 14) + bytes(8)
    content = head + bad + b"".join(enhanced(0, n, bytes([n]) * 4) for n in (1, 2, 3))
    packets, issues = read(content, chunk_size)
    start = len(head) + len(bad)
    assert sorted(packets) == [(start + 36 * (n - 1), 147, bytes([n]) * 4) for n in (1, 2, 3)]
    # The damage is reported where it starts (and again where a chunk resumes inside it).
    assert issues[0] == len(head) and all(len(head) <= at < start for at in issues)


def test_a_header_crc_below_the_right_one_is_no_more_sound_than_one_above() -> None:
    # docs/capture-format.md's example request with its header CRC (0x11ab9b77) replaced.
    request = bytes.fromhex("ffc00c40ffc1fffff0000400")
    for crc in (0, 0x11AB9B76, 0x11AB9B78, 0xFFFFFFFF):
        record = BusRecord(1, RecordType.async_packet, request + struct.pack(">I", crc), 5, 1)
        assert not struct.unpack_from(">H", record_bytes(record), 4)[0] & 0x2  # crc_valid
    sound = BusRecord(1, RecordType.async_packet, request + bytes.fromhex("11ab9b77"), 5, 1)
    assert struct.unpack_from(">H", record_bytes(sound), 4)[0] & 0x2


def test_pcap_resynchronises_one_byte_after_a_stray_byte() -> None:
    # Read one byte early, the 300-byte record's header claims 300 * 256 + 0 bytes
    # (its length shifted by a byte): implausible, so the reader looks again from the
    # next byte, where the record is.
    records = [b"\x01" * 8, b"\x02" * 300, b"\x03" * 8]
    content = classic_pcap(1, records[:1])
    stray = len(content)
    content += b"\xff" + classic_pcap(1, records[1:])[24:]
    packets, issues = read(content, 1 << 20)
    assert [data for _, _, data in packets] == records
    assert issues == [stray]


def test_a_block_length_of_no_whole_quadlets_is_no_packet_block_even_with_its_trailer() -> None:
    head = section() + interface(147)
    bad = struct.pack("<II", 0x99, 14) + bytes(8)
    fake = struct.pack("<II", 6, 34) + bytes(20) + struct.pack("<I", 34)
    real = enhanced(0, 7, b"\x77" * 4)
    packets, issues = read(head + bad + fake + real, 1 << 20)
    assert [(position, data) for position, _, data in packets] == [
        (len(head) + len(bad) + len(fake), b"\x77" * 4)
    ]
    assert issues == [len(head)]
