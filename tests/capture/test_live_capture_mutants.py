"""The live capture loop, the bus tap and the recorder, in process, against stand-ins.

Frames are built here from the tunnel's wire format (docs/virtual-bus.md, "The
tunnel's wire format": a 24-byte big-endian header, ack payloads of ack byte,
tlabel, reserved u16 and acked sequence number, a keyed trailer of an 8-byte
counter and a BLAKE2s-128 MAC), handed to the tap by a stand-in medium, and what
comes out is checked byte by byte against the trace format of
docs/capture-format.md (the 12-byte pseudo-header and its flags) inside the pcapng
and classic pcap containers, whose block layouts are written here from the pcapng
specification and libpcap's file format. Packets are IEEE 1394 quadlets from the
examples of those documents, their CRCs recomputed bit by bit here.
"""

from __future__ import annotations

import hashlib
import io
import os
import signal
import socket
import struct
import threading
import time
from collections import deque
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from spec_crc import crc32_1394

from fw1394.capture.formats import bus_recorder, bus_tap, live
from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.live import ACK_GRACE_S, CaptureError, Limits, capture_records
from fw1394.capture.formats.pcap_writer import PcapngWriter, PcapWriter
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.transport.sansio.config import BusConfig

# -- the tunnel's frames (docs/virtual-bus.md) ----------------------------------------------------

ASYNC, ACK, PHY, JOIN, BEACON, BUS_RESET, RESET_REQUEST, REFUSED = 1, 2, 3, 16, 19, 20, 21, 22
NO_PHY, BROADCAST, EVERY_MEMBER = 0xFF, 63, 0xFF
S400 = 2
MEMBER_ID = 0x0BADF00D


def frame(
    kind: int,
    *,
    generation: int = 5,
    sender: int = 1,
    destination: int = EVERY_MEMBER,
    sequence: int = 0,
    payload: bytes = b"",
    speed: int = S400,
    member: int = MEMBER_ID,
) -> bytes:
    tag = hashlib.sha256(b"fw1394-bus:tapped").digest()[4:8]
    header = struct.pack(
        ">HBB4sIIBBBBI",
        0x4657,
        1,
        kind,
        tag,
        member,
        generation,
        sender,
        destination,
        speed,
        0,
        sequence,
    )
    return header + payload


def ack_byte(code: int) -> int:
    """IEEE 1394 ack: the code in the high nibble, its one's complement in the low one."""
    return code << 4 | (~code & 0xF)


def ack_payload(code: int, tlabel: int, acked_sequence: int, concatenated: bytes = b"") -> bytes:
    return struct.pack(">BBHI", ack_byte(code), tlabel, 0, acked_sequence) + concatenated


def seal(raw: bytes, key: bytes, counter: int) -> bytes:
    body = raw + struct.pack(">Q", counter)
    return body + hashlib.blake2s(body, key=key, digest_size=16).digest()


# -- IEEE 1394 packets --------------------------------------------------------------------------


def with_crc(header: bytes) -> bytes:
    return header + struct.pack(">I", crc32_1394(header))


#: docs/capture-format.md's example: quadlet read request 0xFFC1 -> 0xFFC0, tlabel 3.
READ_REQUEST = bytes.fromhex("ffc00c40ffc1fffff000040011ab9b77")
#: Its answer (tcode 6): destination 0xFFC1, tlabel 3, source 0xFFC0, rcode 0, data "QLA1".
READ_RESPONSE = with_crc(
    struct.pack(">4I", 0xFFC1 << 16 | 3 << 10 | 6 << 4, 0xFFC0 << 16, 0, 0x514C4131)
)
#: A self-ID of physical ID 0 (link active, gap count 63) and its inverse.
SELF_ID = bytes.fromhex("807f00007f80ffff")
ACK_COMPLETE, ACK_PENDING, ACK_BUSY_X = 1, 2, 4


# -- the trace format (docs/capture-format.md) and its containers -------------------------------

CRC_PRESENT, CRC_VALID, CRC_PLACEHOLDER, ACK_PRESENT = 0x1, 0x2, 0x4, 0x8


def pseudo_header(
    record_type: int,
    *,
    flags: int,
    ack: int = 0,
    generation: int = 5,
    sender: int = 0xFF,
    speed: int = S400,
) -> bytes:
    return struct.pack(
        ">BBBBHBBBBH", 1, 12, record_type, speed, flags, ack, generation, sender, 0xFF, 0
    )


def pcapng_blocks(raw: bytes) -> list[tuple[int, bytes]]:
    """(block type, body) of each block of a little-endian pcapng file."""
    blocks, pos = [], 0
    while pos < len(raw):
        kind, length = struct.unpack_from("<II", raw, pos)
        assert struct.unpack_from("<I", raw, pos + length - 4) == (length,)
        blocks.append((kind, raw[pos + 8 : pos + length - 4]))
        pos += length
    return blocks


def options(body: bytes) -> dict[int, bytes]:
    found, pos = {}, 0
    while pos + 4 <= len(body):
        code, length = struct.unpack_from("<HH", body, pos)
        if code == 0:
            break
        found[code] = body[pos + 4 : pos + 4 + length]
        pos += 4 + length + (-length % 4)
    return found


def enhanced_packets(raw: bytes) -> list[tuple[int, bytes]]:
    """(timestamp in ns, packet) of each Enhanced Packet Block, after one SHB and one IDB
    of link type 147 with nanosecond timestamps."""
    (shb, shb_body), (idb, idb_body), *packets = pcapng_blocks(raw)
    assert shb == 0x0A0D0D0A and struct.unpack_from("<IHH", shb_body) == (0x1A2B3C4D, 1, 0)
    assert idb == 1 and struct.unpack_from("<HHI", idb_body) == (147, 0, 0)
    assert options(idb_body[8:])[9] == b"\x09"  # if_tsresol: nanoseconds
    found = []
    for kind, body in packets:
        assert kind == 6
        interface, high, low, captured, original = struct.unpack_from("<5I", body)
        assert interface == 0 and captured == original
        found.append((high << 32 | low, body[20 : 20 + captured]))
    return found


def pcapng_writer() -> tuple[PcapngWriter, io.BytesIO]:
    stream = io.BytesIO()
    return PcapngWriter(stream, 147), stream


# -- a stand-in for the bus medium -------------------------------------------------------------


class StandInMedium:
    """The medium of a tap: frames handed in by the test, each with its kernel stamp.

    A frame may be held back until a monotonic time; a blocking read on a quiet
    medium returns nothing after a short poll, as a socket with a timeout does.
    """

    def __init__(self, config: BusConfig) -> None:
        self.config = config
        self.frames: deque[tuple[float, bytes, int]] = deque()
        self.reads: list[bool] = []
        self.taps = 0
        self.closes = 0

    def add(self, raw: bytes, stamp_ns: int, after: float = 0.0) -> None:
        self.frames.append((time.monotonic() + after, raw, stamp_ns))

    def filter_as_tap(self) -> None:
        self.taps += 1

    def receive_stamped(self, wait: bool = True) -> tuple[bytes, int] | None:
        self.reads.append(wait)
        if self.frames and self.frames[0][0] <= time.monotonic():
            _, raw, stamp = self.frames.popleft()
            return raw, stamp
        if wait:
            time.sleep(0.001)
        return None

    def close(self) -> None:
        self.closes += 1


class Media(list[StandInMedium]):
    """The media taps opened, in order; each made by ``kind``."""

    kind: type[StandInMedium] = StandInMedium


@pytest.fixture
def media(monkeypatch: pytest.MonkeyPatch) -> Media:
    """Every medium a tap opens from now on: a stand-in."""
    opened = Media()

    def open_medium(config: BusConfig, *args: object, **kwargs: object) -> StandInMedium:
        opened.append(opened.kind(config))
        return opened[-1]

    monkeypatch.setattr(bus_tap, "open_medium", open_medium)
    for name in ("FW1394_BUS_KEY", "FW1394_BUS_KEY_FILE"):
        monkeypatch.delenv(name, raising=False)
    return opened


def tap_with(media: Media, frames: list[bytes], **options: Any) -> BusTap:
    tap = BusTap("tapped", key=options.pop("key", b""), **options)
    for number, raw in enumerate(frames):
        media[-1].add(raw, 1_700_000_000_000_000_000 + 1000 * number)
    return tap


def drain(tap: BusTap, timeout: float = 0.1) -> list[BusRecord]:
    records = []
    while (record := tap.receive(timeout)) is not None:
        records.append(record)
    return records


# -- the bus tap ----------------------------------------------------------------------------------


def test_a_tap_listens_to_its_bus_as_a_tap_and_closes_its_medium_once(
    media: Media,
) -> None:
    with BusTap("tapped", key=b"") as tap:
        (medium,) = media
        assert medium.config.name == "tapped" and medium.config.interface == "127.0.0.1"
        assert medium.taps == 1
        assert tap.dropped is None  # an insecure bus: nothing is checked, nothing dropped
        tap.close()
    assert medium.closes == 1


def test_every_frame_kind_becomes_its_record_and_other_frames_none(
    media: Media,
) -> None:
    member_table = struct.pack(">IHH", 0, 1, 0) + bytes(24)
    tap = tap_with(
        media,
        [
            frame(BUS_RESET, generation=6, sender=NO_PHY, payload=member_table),
            frame(PHY, generation=6, sender=0, speed=0, payload=SELF_ID),
            frame(JOIN, generation=6, payload=bytes(28)),
            frame(BEACON, generation=6, payload=member_table),
            frame(RESET_REQUEST, generation=6),
            frame(REFUSED, generation=6, payload=struct.pack(">I", 5) + b"full"),
            b"GW" + frame(PHY, generation=6, payload=SELF_ID)[2:],  # not the tunnel's magic
            frame(PHY, generation=6)[:20],  # shorter than a header
            frame(
                ASYNC, generation=6, sender=NO_PHY, destination=0, sequence=9, payload=READ_REQUEST
            ),
        ],
        ack_wait=30.0,
    )
    records = drain(tap)
    base = 1_700_000_000_000_000_000
    assert records == [
        BusRecord(base, RecordType.bus_reset, b"", 6, None, S400),
        BusRecord(base + 1000, RecordType.phy_packet, SELF_ID, 6, 0, 0),
        # From no node yet: no ack can be told to it, so it is not held for one.
        BusRecord(base + 8000, RecordType.async_packet, READ_REQUEST, 6, None, S400),
    ]


def test_a_packet_comes_out_with_the_ack_that_names_its_frame(media: Media) -> None:
    tap = tap_with(
        media,
        [
            frame(ASYNC, sender=1, destination=0, sequence=41, payload=READ_REQUEST),
            # Acks of other frames: another sequence, another sender, another generation.
            frame(
                ACK, sender=0, destination=1, sequence=500, payload=ack_payload(ACK_BUSY_X, 3, 40)
            ),
            frame(
                ACK, sender=0, destination=2, sequence=501, payload=ack_payload(ACK_BUSY_X, 3, 41)
            ),
            frame(
                ACK,
                generation=4,
                sender=0,
                destination=1,
                sequence=502,
                payload=ack_payload(ACK_BUSY_X, 3, 41),
            ),
            frame(
                ACK, sender=0, destination=1, sequence=503, payload=bytes(7)
            ),  # too short: dropped
            frame(
                ACK, sender=0, destination=1, sequence=504, payload=ack_payload(ACK_PENDING, 3, 41)
            ),
        ],
        ack_wait=30.0,
    )
    started = time.monotonic()
    records = drain(tap)
    assert time.monotonic() - started < 10.0  # out when acked, not when ack_wait runs out
    assert [(r.record_type, r.ack, r.data) for r in records] == [
        (RecordType.async_packet, ACK_PENDING, READ_REQUEST),
        (RecordType.ack, None, bytes([ack_byte(ACK_BUSY_X)])),
        (RecordType.ack, None, bytes([ack_byte(ACK_BUSY_X)])),
        (RecordType.ack, None, bytes([ack_byte(ACK_BUSY_X)])),
        (RecordType.ack, None, bytes([ack_byte(ACK_PENDING)])),
    ]
    assert [(r.sender, r.generation) for r in records] == [(1, 5), (0, 5), (0, 5), (0, 4), (0, 5)]


def test_a_response_behind_an_ack_is_its_own_packet_acked_under_the_ack_frames_number(
    media: Media,
) -> None:
    tap = tap_with(
        media,
        [
            frame(ASYNC, sender=1, destination=0, sequence=7, payload=READ_REQUEST),
            frame(
                ACK,
                sender=0,
                destination=1,
                sequence=90,
                payload=ack_payload(ACK_PENDING, 3, 7, READ_RESPONSE),
            ),
            frame(
                ACK, sender=1, destination=0, sequence=8, payload=ack_payload(ACK_COMPLETE, 3, 90)
            ),
        ],
        ack_wait=30.0,
    )
    records = drain(tap)
    assert [(r.record_type, r.sender, r.ack, r.data) for r in records] == [
        (RecordType.async_packet, 1, ACK_PENDING, READ_REQUEST),
        (RecordType.ack, 0, None, bytes([ack_byte(ACK_PENDING)])),
        (RecordType.async_packet, 0, ACK_COMPLETE, READ_RESPONSE),
        (RecordType.ack, 1, None, bytes([ack_byte(ACK_COMPLETE)])),
    ]
    # The response is stamped when the ack frame that carried it arrived.
    assert records[2].timestamp_ns == records[1].timestamp_ns


def test_a_broadcast_packet_waits_for_no_ack(media: Media) -> None:
    write = bytes.fromhex("ffff0400ffd000000000000b0100007f11c036d8")  # jhu-eth1394.md §1.6
    tap = tap_with(
        media, [frame(ASYNC, sender=2, destination=BROADCAST, payload=write)], ack_wait=30.0
    )
    (record,) = drain(tap)
    assert (record.data, record.ack, record.sender) == (write, None, 2)


def test_an_unacked_packet_is_held_for_ack_wait_and_a_late_ack_comes_alone(
    media: Media,
) -> None:
    tap = tap_with(
        media,
        [frame(ASYNC, sender=1, destination=0, sequence=3, payload=READ_REQUEST)],
        ack_wait=0.4,
    )
    started = time.monotonic()
    assert tap.receive(0.03) is None  # still waiting for its ack
    record = tap.receive(2.0)
    assert record is not None and record.ack is None and record.data == READ_REQUEST
    assert time.monotonic() - started >= 0.4
    media[0].add(
        frame(ACK, sender=0, destination=1, sequence=4, payload=ack_payload(ACK_COMPLETE, 3, 3)), 1
    )
    late = tap.receive(0.5)
    assert late is not None and late.record_type == RecordType.ack


def test_a_tap_holds_packets_for_the_default_ack_wait_of_50_ms(media: Media) -> None:
    tap = tap_with(media, [frame(ASYNC, sender=1, destination=0, sequence=3, payload=READ_REQUEST)])
    started = time.monotonic()
    record = tap.receive(0.6)
    assert record is not None and record.ack is None
    assert time.monotonic() - started >= 0.05


def test_stamps_never_go_back(media: Media) -> None:
    tap = BusTap("tapped", key=b"")
    for stamp in (2000, 1500, 2500, 2400):
        media[0].add(frame(PHY, payload=SELF_ID), stamp)
    assert [r.timestamp_ns for r in drain(tap)] == [2000, 2000, 2500, 2500]


def test_a_keyed_tap_records_sealed_frames_and_drops_forged_and_replayed_ones(
    media: Media,
) -> None:
    key = bytes(range(32))
    sealed = seal(frame(PHY, payload=SELF_ID), key, 1)
    forged = bytearray(seal(frame(PHY, payload=SELF_ID), key, 2))
    forged[-1] ^= 1
    other = seal(frame(BUS_RESET, generation=6, sender=NO_PHY), key, 3)
    tap = tap_with(media, [sealed, bytes(forged), sealed, other], key=key)
    records = drain(tap)
    assert [(r.record_type, r.data) for r in records] == [
        (RecordType.phy_packet, SELF_ID),
        (RecordType.bus_reset, b""),
    ]
    assert tap.dropped is not None
    assert (tap.dropped.forged, tap.dropped.replayed) == (1, 1)


def test_an_idle_tap_sleeps_in_the_medium_and_a_busy_one_polls_it(
    media: Media,
) -> None:
    tap = BusTap("tapped", key=b"")
    medium = media[0]
    assert tap.receive(0.01) is None
    assert medium.reads and all(medium.reads)  # quiet bus: blocking reads only
    medium.reads.clear()
    medium.add(frame(PHY, payload=SELF_ID), 1)
    assert tap.receive(1.0) is not None
    assert tap.receive(0.02) is None
    # Right after a frame the bus is busy: the tap takes what is queued without
    # blocking, and sleeps between looks.
    assert medium.reads[:2] == [True, False]
    time.sleep(0.06)  # longer than the bus stays busy after a frame
    medium.reads.clear()
    assert tap.receive(0.005) is None
    assert medium.reads and all(medium.reads)


def test_a_busy_tap_sees_a_frame_within_its_batch_interval(media: Media) -> None:
    tap = BusTap("tapped", key=b"")
    media[0].add(frame(PHY, payload=SELF_ID), 1)
    assert tap.receive(1.0) is not None
    media[0].add(frame(PHY, payload=SELF_ID), 2, after=0.01)
    started = time.monotonic()
    record = tap.receive(1.0)
    assert record is not None and record.timestamp_ns == 2
    assert time.monotonic() - started < 0.9


def test_iterating_a_tap_yields_its_records_until_it_is_closed(media: Media) -> None:
    tap = BusTap("tapped", key=b"")
    for stamp in (1, 2, 3):
        media[0].add(frame(PHY, payload=SELF_ID), stamp)
    seen: list[int] = []

    def iterate() -> None:
        for record in tap:
            seen.append(record.timestamp_ns)

    reader = threading.Thread(target=iterate, daemon=True)
    reader.start()
    deadline = time.monotonic() + 5.0
    while len(seen) < 3 and time.monotonic() < deadline:
        time.sleep(0.005)
    tap.close()
    reader.join(0.8)  # a closed tap ends the iteration within its 0.1 s look
    stuck = reader.is_alive()
    assert seen == [1, 2, 3] and not stuck


# -- the capture loop ----------------------------------------------------------------------------


class ScriptedSource:
    """Records to hand out, one per receive; None when none is left. Each receive's
    timeout is kept; ``on_empty`` runs when the script has run out."""

    def __init__(self, records: list[BusRecord], on_empty: Callable[[], None] | None = None):
        self.records = deque(records)
        self.timeouts: list[float] = []
        self.on_empty = on_empty

    def receive(self, timeout: float) -> BusRecord | None:
        self.timeouts.append(timeout)
        if not self.records and self.on_empty is not None:
            self.on_empty()
        return self.records.popleft() if self.records else None


STAMP = 1_700_000_000_123_456_789


def packet(sequence: int, ack: int | None = ACK_COMPLETE) -> BusRecord:
    return BusRecord(STAMP + sequence, RecordType.async_packet, READ_REQUEST, 5, 1, S400, ack=ack)


def ack(sequence: int, code: int = ACK_COMPLETE) -> BusRecord:
    return BusRecord(STAMP + sequence, RecordType.ack, bytes([ack_byte(code)]), 5, 0, S400)


def test_a_tapped_bus_is_written_as_the_documented_blocks(media: Media) -> None:
    tap = tap_with(
        media,
        [
            frame(ASYNC, sender=1, destination=0, sequence=41, payload=READ_REQUEST),
            frame(
                ACK, sender=0, destination=1, sequence=504, payload=ack_payload(ACK_PENDING, 3, 41)
            ),
            frame(PHY, sender=0, payload=SELF_ID),
        ],
        ack_wait=30.0,
    )
    writer, stream = pcapng_writer()
    shown: list[str] = []
    assert capture_records(tap, writer, Limits(threading.Event(), count=2), shown.append) == 2
    base = 1_700_000_000_000_000_000
    assert enhanced_packets(stream.getvalue()) == [
        (
            base,
            pseudo_header(0, flags=CRC_PRESENT | CRC_VALID | ACK_PRESENT, ack=ACK_PENDING, sender=1)
            + READ_REQUEST,
        ),
        (base + 1000, pseudo_header(1, flags=CRC_PRESENT, sender=0) + bytes([0x2D])),
        (base + 2000, pseudo_header(2, flags=CRC_PRESENT | CRC_VALID, sender=0) + SELF_ID),
    ]
    assert shown[0].startswith("1700000000.000000 g5 read_quadlet_request ffc1 -> ffc0 tl=3")
    assert shown[0].endswith("  ack_pending")
    assert shown[1] == "1700000000.000001 g5   ack_pending"
    assert shown[2].startswith("1700000000.000002 g5 self_id phy_id=0 link_active gap_count=63")


def test_a_count_counts_packets_and_the_acks_of_the_last_come_along() -> None:
    source = ScriptedSource([packet(1), ack(2), packet(3), ack(4), ack(5), packet(6), ack(7)])
    writer, stream = pcapng_writer()
    assert capture_records(source, writer, Limits(threading.Event(), count=2)) == 2
    kinds = [data[2] for _, data in enhanced_packets(stream.getvalue())]
    assert kinds == [0, 1, 0, 1, 1]  # packet 6, past the count, is not written
    grace = source.timeouts[3:]
    assert len(grace) == 3 and all(0 < left <= 0.2 for left in grace)


def test_the_acks_after_the_count_are_awaited_only_for_the_grace_time() -> None:
    endless = ScriptedSource([packet(1), ack(2)])

    def more_acks() -> None:
        time.sleep(0.02)
        endless.records.append(ack(2))

    endless.on_empty = more_acks
    started = time.monotonic()
    assert capture_records(endless, pcapng_writer()[0], Limits(threading.Event(), count=1)) == 1
    assert 0.15 <= time.monotonic() - started < 5.0
    assert all(left > 0 for left in endless.timeouts)  # never asked to wait for nothing


def test_a_capture_that_runs_out_of_time_before_its_count_waits_for_no_acks() -> None:
    class Acks(ScriptedSource):
        def receive(self, timeout: float) -> BusRecord | None:
            self.timeouts.append(timeout)
            time.sleep(min(timeout, 0.01))
            return ack(0)

    source = Acks([])
    limits = Limits(threading.Event(), duration=0.05, count=100)
    assert capture_records(source, pcapng_writer()[0], limits) == 0
    assert source.timeouts and max(source.timeouts) <= 0.05  # no grace after the time is up


def test_a_stop_request_takes_what_is_queued_then_ends() -> None:
    # Ctrl-C after the first packet: what already reached the tap is written, the
    # next packet included (past the count, but queued before the stop), each
    # receive waiting no longer than the grace time; the first empty one ends it.
    stop = threading.Event()
    source = ScriptedSource([packet(1), ack(2), packet(3), ack(4)])
    writer, stream = pcapng_writer()
    assert capture_records(source, writer, Limits(stop, count=1), lambda line: stop.set()) == 2
    assert len(source.timeouts) == 5 and all(0 < t <= ACK_GRACE_S for t in source.timeouts[1:])
    assert len(enhanced_packets(stream.getvalue())) == 4


class EndlessSource:
    """A bus that never goes quiet: a packet on every receive."""

    def __init__(self) -> None:
        self.handed = 0

    def receive(self, timeout: float) -> BusRecord | None:
        self.handed += 1
        return packet(self.handed)


@pytest.mark.timeout(30)  # without the grace time's bound, the capture never ends
def test_a_stop_request_ends_a_busy_capture_within_the_grace_time() -> None:
    stop = threading.Event()
    stop.set()
    busy = EndlessSource()
    writer, _ = pcapng_writer()
    assert capture_records(busy, writer, Limits(stop)) == busy.handed > 0


def test_a_capture_without_limits_polls_a_few_times_a_second_for_a_stop() -> None:
    stop = threading.Event()
    source = ScriptedSource(
        [packet(1), ack(2), BusRecord(STAMP, RecordType.bus_reset, b"", 6)], on_empty=stop.set
    )
    writer, stream = pcapng_writer()
    assert capture_records(source, writer, Limits(stop)) == 2  # the packet and the bus reset
    # Four receives until the stop, one more that finds nothing queued after it.
    assert len(source.timeouts) == 5 and all(0 < t <= 0.25 for t in source.timeouts)
    assert len(enhanced_packets(stream.getvalue())) == 3


def test_a_limit_in_time_waits_no_longer_than_what_is_left() -> None:
    stop = threading.Event()
    assert 0.0 < Limits(stop, duration=0.05).wait() <= 0.05
    assert Limits(stop, duration=-1.0).wait() == 0.0
    assert Limits(stop, duration=60.0).wait() == Limits(stop).wait() <= 0.25
    assert not Limits(stop, count=3).done(2) and Limits(stop, count=3).done(4)


class CountingStream(io.BytesIO):
    def __init__(self) -> None:
        super().__init__()
        self.flushes: list[tuple[float, int]] = []

    def flush(self) -> None:
        self.flushes.append((time.monotonic(), len(self.getvalue())))
        super().flush()


def test_a_fast_capture_is_flushed_twice_a_second_not_per_record() -> None:
    stream = CountingStream()
    source = ScriptedSource([packet(n) for n in range(200)])
    started = time.monotonic()
    assert (
        capture_records(source, PcapngWriter(stream, 147), Limits(threading.Event(), count=200))
        == 200
    )
    elapsed = time.monotonic() - started
    assert 1 <= len(stream.flushes) <= 2 + elapsed / 0.5
    assert stream.flushes[-1][1] == len(stream.getvalue())  # the last flush holds everything


def test_a_slow_capture_is_flushed_while_it_runs() -> None:
    stream = CountingStream()
    started = time.monotonic()

    class Trickle:
        def receive(self, timeout: float) -> BusRecord | None:
            time.sleep(min(timeout, 0.05))
            return packet(0)

    capture_records(Trickle(), PcapngWriter(stream, 147), Limits(threading.Event(), duration=1.0))
    during = [size for when, size in stream.flushes if when - started < 0.95]
    assert during and during[0] > 0


# -- the live view -------------------------------------------------------------------------------


def test_each_record_has_its_line_in_the_live_view() -> None:
    line = live.record_summary
    reset = BusRecord(STAMP, RecordType.bus_reset, b"", 7)
    assert line(reset) == "1700000000.123457 g7 bus reset, generation 7"
    assert line(reset, lambda ns: f"<{ns}>") == f"<{STAMP}> g7 bus reset, generation 7"
    assert line(BusRecord(STAMP, RecordType.ack, b"", 5)).endswith("g5   reserved_0x0")
    assert line(ack(0, ACK_BUSY_X)) == "1700000000.123457 g5   ack_busy_X"
    text = line(packet(0, ack=None))
    assert (
        text == "1700000000.123457 g5 read_quadlet_request ffc1 -> ffc0 tl=3 offset=0xfffff0000400"
    )
    assert line(packet(0, ack=ACK_PENDING)) == text + "  ack_pending"
    phy = line(BusRecord(STAMP, RecordType.phy_packet, SELF_ID, 5))
    assert phy.startswith("1700000000.123457 g5 self_id phy_id=0 ")
    broken = line(BusRecord(STAMP, RecordType.async_packet, b"\xff\xc0", 5))
    assert broken.startswith("1700000000.123457 g5 unreadable packet (") and broken.endswith("ffc0")


def test_zero_crcs_of_a_jhu_response_are_shown_as_not_computed() -> None:
    # jhu-eth1394.md §1.6: a quadlet read response as the FPGA sends it over Ethernet.
    response = bytes.fromhex("ffd01c60ffc0000000000000514c413100000000")
    record = BusRecord(STAMP, RecordType.async_packet, response, 5, 0, crc_placeholder=True)
    text = live.record_summary(record)
    assert "[crc not computed]" in text and "does not match" not in text
    assert "read_quadlet_response ffc0 -> ffd0 tl=7" in text
    block = bytes.fromhex("ffd01c70ffc00000000000000004000000000000514c413100000000")
    shown = live.record_summary(
        BusRecord(STAMP, RecordType.async_packet, block, 5, 0, crc_placeholder=True)
    )
    assert "[crc not computed]" in shown and "does not match" not in shown
    plain = live.record_summary(BusRecord(STAMP, RecordType.async_packet, response, 5, 0))
    assert "does not match" in plain


# -- live UDP capture, on a stand-in packet socket -----------------------------------------------

PACKET_HOST, PACKET_OUTGOING = 0, 4


def udp_frame(
    payload: bytes,
    source_port: int = 40000,
    destination_port: int = 1394,
    source: int = 1,
    destination: int = 2,
) -> bytes:
    """Ethernet II, IPv4 (RFC 791, no options), UDP (RFC 768) between 127.0.0.x addresses."""
    udp = struct.pack(">HHHH", source_port, destination_port, 8 + len(payload), 0) + payload
    ip = struct.pack(
        ">BBHHHBBH4s4s",
        0x45,
        0,
        20 + len(udp),
        0,
        0,
        64,
        17,
        0,
        bytes([127, 0, 0, source]),
        bytes([127, 0, 0, destination]),
    )
    return bytes(12) + b"\x08\x00" + ip + udp


class StandInPacketSocket:
    """What a packet socket returns: frames with their (interface, protocol, type) address,
    and a timeout or an interrupted call now and then."""

    def __init__(self, script: list[tuple[bytes, int] | type[OSError]]) -> None:
        self.script = deque(script)
        self.timeouts: list[float] = []
        self.closed = False

    def settimeout(self, seconds: float) -> None:
        self.timeouts.append(seconds)

    def recvfrom(self, size: int) -> tuple[bytes, tuple[str, int, int]]:
        if not self.script:
            raise TimeoutError
        step = self.script.popleft()
        if isinstance(step, type):
            raise step
        raw, kind = step
        return raw, ("lo", 0x0800, kind)

    def close(self) -> None:
        self.closed = True


def test_a_live_udp_capture_writes_each_eth1394_frame_once(monkeypatch: pytest.MonkeyPatch) -> None:
    request = bytes.fromhex("0105ffc01c40ffd0000000000004a9927b79")  # jhu-eth1394.md §1.6
    response = bytes.fromhex("ffd01c60ffc0000000000000514c41310000000010050000006400c8")
    sent = udp_frame(request)
    answer = udp_frame(response, 1394, 40000, source=2, destination=1)
    stand_in = StandInPacketSocket(
        [
            (sent, PACKET_OUTGOING),
            (sent, PACKET_HOST),
            TimeoutError,
            InterruptedError,
            (udp_frame(b"other", 40000, 53), PACKET_HOST),
            (answer, PACKET_HOST),
        ]
    )
    opened: list[str] = []

    def open_raw_socket(interface: str) -> StandInPacketSocket:
        opened.append(interface)
        return stand_in

    monkeypatch.setattr(live, "open_raw_socket", open_raw_socket)
    stream = io.BytesIO()
    shown: list[str] = []
    writer = PcapWriter(stream, 1)
    assert (
        live.capture_udp("lo", (1394,), writer, Limits(threading.Event(), count=2), shown.append)
        == 2
    )
    assert opened == ["lo"] and stand_in.closed
    assert all(0.01 <= t <= 0.25 for t in stand_in.timeouts)
    raw = stream.getvalue()
    assert struct.unpack_from("<IHHiIII", raw) == (0xA1B23C4D, 2, 4, 0, 0, 262144, 1)
    records, pos = [], 24
    while pos < len(raw):
        _, _, captured, original = struct.unpack_from("<IIII", raw, pos)
        assert captured == original
        records.append(raw[pos + 16 : pos + 16 + captured])
        pos += 16 + captured
    assert records == [sent, answer]
    assert shown[0].startswith("127.0.0.1 -> 127.0.0.2 ")
    assert "read_quadlet_request ffd0 -> ffc0 tl=7" in shown[0]
    assert shown[1].startswith("127.0.0.2 -> 127.0.0.1 ")
    assert "read_quadlet_response ffc0 -> ffd0 tl=7" in shown[1]


def test_off_loopback_a_hosts_own_frames_are_its_traffic(monkeypatch: pytest.MonkeyPatch) -> None:
    request = bytes.fromhex("0105ffc01c40ffd0000000000004a9927b79")
    stand_in = StandInPacketSocket([(b"\x01", PACKET_HOST), (udp_frame(request), PACKET_OUTGOING)])
    monkeypatch.setattr(live, "open_raw_socket", lambda interface: stand_in)
    stream = io.BytesIO()
    limits = Limits(threading.Event(), count=1)
    assert live.capture_udp("eth0", (1394,), PcapWriter(stream, 1), limits) == 1
    assert len(stream.getvalue()) == 24 + 16 + len(udp_frame(request))


def test_a_live_udp_capture_summarises_a_datagram_that_is_not_eth1394(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    stand_in = StandInPacketSocket([(udp_frame(b"\x01"), PACKET_HOST)])
    monkeypatch.setattr(live, "open_raw_socket", lambda interface: stand_in)
    shown: list[str] = []
    live.capture_udp(
        "lo", (1394,), PcapWriter(io.BytesIO(), 1), Limits(threading.Event(), count=1), shown.append
    )
    (line,) = shown
    seconds = line.split()[0]
    assert abs(float(seconds) - time.time()) < 60  # seconds since the epoch, as captured
    assert line.endswith(" 127.0.0.1 -> 127.0.0.2 UDP 1394 datagram of 1 bytes is not Eth1394")


def _packet_sockets_allowed() -> bool:
    try:
        socket.socket(socket.AF_PACKET, socket.SOCK_RAW, 0).close()
    except PermissionError:
        return False
    return True


def test_a_slow_live_udp_capture_is_flushed_while_it_runs(monkeypatch: pytest.MonkeyPatch) -> None:
    request = bytes.fromhex("0105ffc01c40ffd0000000000004a9927b79")

    class Trickling(StandInPacketSocket):
        def recvfrom(self, size: int) -> tuple[bytes, tuple[str, int, int]]:
            time.sleep(0.05)
            return udp_frame(request), ("eth0", 0x0800, PACKET_HOST)

    monkeypatch.setattr(live, "open_raw_socket", lambda interface: Trickling([]))
    stream = CountingStream()
    started = time.monotonic()
    limits = Limits(threading.Event(), duration=1.0)
    assert live.capture_udp("eth0", (1394,), PcapWriter(stream, 1), limits) > 0
    elapsed = time.monotonic() - started
    during = [size for when, size in stream.flushes if when - started < 0.95]
    assert during and during[0] > 24
    assert len(stream.flushes) <= 2 + elapsed / 0.5  # twice a second, not once a frame


@pytest.mark.skipif(not hasattr(socket, "AF_PACKET"), reason="needs Linux packet sockets")
def test_a_packet_socket_that_cannot_open_is_one_line_for_the_user() -> None:
    with pytest.raises(CaptureError) as caught:
        live.open_raw_socket("nosuch0")
    if _packet_sockets_allowed():
        assert str(caught.value).startswith("interface nosuch0: ")
    else:
        assert "CAP_NET_RAW" in str(caught.value)


@pytest.mark.skipif(not hasattr(socket, "AF_PACKET"), reason="needs Linux packet sockets")
def test_a_packet_socket_on_loopback_has_a_large_receive_buffer() -> None:
    if not _packet_sockets_allowed():
        pytest.skip("packet sockets need CAP_NET_RAW")
    raw = live.open_raw_socket("lo")
    try:
        assert raw.family == socket.AF_PACKET
        limit = int(Path("/proc/sys/net/core/rmem_max").read_text())
        # Linux doubles what it is asked for, up to twice rmem_max.
        assert raw.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF) >= 2 * min(8 << 20, limit)
    finally:
        raw.close()


@pytest.mark.skipif(not hasattr(socket, "AF_PACKET"), reason="needs Linux packet sockets")
def test_a_live_udp_capture_on_loopback_keeps_one_copy_of_each_datagram() -> None:
    # The kernel shows a packet socket on lo every frame twice, leaving and arriving.
    if not _packet_sockets_allowed():
        pytest.skip("packet sockets need CAP_NET_RAW")
    with (
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as receiver,
        socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sender,
    ):
        receiver.bind(("127.0.0.1", 0))
        port = receiver.getsockname()[1]
        done = threading.Event()

        def send_requests() -> None:
            tlabel = 0
            while not done.wait(0.02):
                header = struct.pack(">3I", 0xFFC0 << 16 | tlabel << 10 | 4 << 4, 0xFFD00000, 4)
                sender.sendto(b"\x01\x05" + with_crc(header), ("127.0.0.1", port))
                tlabel = (tlabel + 1) % 64

        sending = threading.Thread(target=send_requests, daemon=True)
        sending.start()
        stream = io.BytesIO()
        try:
            limits = Limits(threading.Event(), duration=5.0, count=2)
            captured = live.capture_udp("lo", (port,), PcapWriter(stream, 1), limits)
        finally:
            done.set()
            sending.join()
    raw = stream.getvalue()
    frames, pos = [], 24
    while pos < len(raw):
        captured_length = struct.unpack_from("<I", raw, pos + 8)[0]
        frames.append(raw[pos + 16 : pos + 16 + captured_length])
        pos += 16 + captured_length
    assert captured == len(frames) == 2
    for ethernet in frames:
        assert ethernet[12:14] == b"\x08\x00" and ethernet[14 + 9] == 17  # IPv4, UDP
        assert struct.unpack_from(">H", ethernet, 14 + 20 + 2) == (port,)
    tlabels = [
        struct.unpack_from(">I", ethernet, 14 + 28 + 2)[0] >> 10 & 0x3F for ethernet in frames
    ]
    assert tlabels[1] == (tlabels[0] + 1) % 64  # two datagrams, not one seen twice


# -- the recorder --------------------------------------------------------------------------------


def test_a_recorders_pcapng_file_names_its_bus(tmp_path: Path) -> None:
    path = tmp_path / "bus.pcapng"
    bus_recorder.open_writer(path, "lab").close()
    (_, shb_body), (idb, idb_body) = pcapng_blocks(path.read_bytes())
    assert options(shb_body[16:])[4].startswith(b"fw1394 ")  # shb_userappl
    assert idb == 1 and struct.unpack_from("<HHI", idb_body) == (147, 0, 0)
    found = options(idb_body[8:])
    assert (found[2], found[3], found[9]) == (b"fw1394", b"fw1394 virtual bus lab", b"\x09")


def test_a_recorders_pcap_file_has_link_type_147_in_nanoseconds(tmp_path: Path) -> None:
    path = tmp_path / "bus.pcap"
    bus_recorder.open_writer(path, "lab", pcap=True).close()
    assert struct.unpack("<IHHiIII", path.read_bytes()) == (0xA1B23C4D, 2, 4, 0, 0, 262144, 147)


def test_recording_a_bus_writes_its_records_until_the_count(
    media: Media,
    tmp_path: Path,
) -> None:
    path = tmp_path / "bus.pcapng"
    shown: list[str] = []

    class Feeding(threading.Thread):
        def run(self) -> None:
            while not media:
                time.sleep(0.001)
            for stamp in (10, 20, 30):
                media[0].add(frame(PHY, sender=0, payload=SELF_ID), stamp)

    Feeding(daemon=True).start()
    assert (
        bus_recorder.record_bus("tapped", path, threading.Event(), count=2, show=shown.append) == 2
    )
    assert media[0].closes == 1
    assert enhanced_packets(path.read_bytes()) == [
        (stamp, pseudo_header(2, flags=CRC_PRESENT | CRC_VALID, sender=0) + SELF_ID)
        for stamp in (10, 20)
    ]
    assert len(shown) == 2 and "self_id" in shown[0]


def test_a_recorders_file_header_is_on_disk_once_its_tap_listens(
    media: Media,
    tmp_path: Path,
) -> None:
    # Programs that start the recorder as a process wait for the header to know
    # that their traffic will be recorded.
    path = tmp_path / "bus.pcapng"
    on_disk: list[int] = []

    class Listening(StandInMedium):
        def receive_stamped(self, wait: bool = True) -> tuple[bytes, int] | None:
            on_disk.append(path.stat().st_size)
            return super().receive_stamped(wait)

    media.kind = Listening
    bus_recorder.record_bus("tapped", path, threading.Event(), duration=0.02)
    assert on_disk and on_disk[0] == len(path.read_bytes()) > 0


def test_recording_for_a_while_in_pcap_writes_the_header_alone(
    media: Media,
    tmp_path: Path,
) -> None:
    path = tmp_path / "bus.pcap"
    assert bus_recorder.record_bus("tapped", path, threading.Event(), duration=0.05, pcap=True) == 0
    assert len(path.read_bytes()) == 24 and media[0].closes == 1


@pytest.fixture
def signals() -> Iterator[None]:
    """Whatever the recorder sets for SIGINT and SIGTERM is undone afterwards."""
    saved = {number: signal.getsignal(number) for number in (signal.SIGINT, signal.SIGTERM)}
    yield
    for number, handler in saved.items():
        signal.signal(number, handler)


def test_the_recorder_process_entry_checks_its_arguments(
    capsys: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    def record_bus(*args: object, **kwargs: object) -> int:
        raise AssertionError("a recording started")

    monkeypatch.setattr(bus_recorder, "record_bus", record_bus)
    assert bus_recorder.main(["tapped"]) == 2
    assert bus_recorder.main(["tapped", "a", "b"]) == 2
    assert (
        capsys.readouterr().err.count("usage: python -m fw1394.capture.formats.bus_recorder") == 2
    )


@pytest.mark.usefixtures("signals")
def test_the_recorder_process_entry_records_until_sigterm(
    media: Media,
    tmp_path: Path,
) -> None:
    path = tmp_path / "bus.pcapng"

    def terminate_once_listening() -> None:
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline and not (path.exists() and path.stat().st_size):
            time.sleep(0.005)
        media[0].add(frame(PHY, sender=0, payload=SELF_ID), 77)
        while media[0].frames and time.monotonic() < deadline:
            time.sleep(0.005)  # once the tap has taken it, its record is written
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=terminate_once_listening, daemon=True).start()
    assert bus_recorder.main(["tapped", str(path)]) == 0
    assert [stamp for stamp, _ in enhanced_packets(path.read_bytes())] == [77]


@pytest.mark.usefixtures("signals")
def test_the_recorder_process_entry_says_why_it_cannot_write(
    media: Media,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
) -> None:
    missing = tmp_path / "no such directory" / "bus.pcapng"
    assert bus_recorder.main(["tapped", str(missing)]) == 1
    assert capsys.readouterr().err.startswith(f"fw1394 capture: {missing}: ")


def test_a_packet_socket_refused_for_want_of_privilege_is_one_line(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    def refused(*args: object) -> socket.socket:
        raise PermissionError(1, "Operation not permitted")

    monkeypatch.setattr(socket, "socket", refused)  # the module live opens it from
    with pytest.raises(CaptureError, match="CAP_NET_RAW"):
        live.open_raw_socket("lo")
