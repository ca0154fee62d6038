"""Live capture: a virtual bus through its tap, or Eth1394 UDP traffic off an interface.

Both loops write every record as soon as it arrives and stop between two
records when asked (Ctrl-C, a duration or a count), so the file is always
complete. Writing is buffered; the writer is flushed twice a second.
"""

from __future__ import annotations

import socket
import threading
import time
from collections.abc import Callable
from dataclasses import replace
from typing import Any, Protocol

from fw1394.capture.formats import eth1394_udp as udp
from fw1394.capture.formats import trace_writer as tracefile
from fw1394.capture.formats.pcap_writer import LINKTYPE_ETHERNET, PcapngWriter, PcapWriter
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.errors import Error
from fw1394.packets import AckCode, AsyncPacket, PacketError, decode, name_of, summary
from fw1394.packets.ack import ack_code

POLL_S = 0.2
FLUSH_S = 0.5
ETH_P_ALL = 0x0003
PACKET_OUTGOING = 4
LOOPBACK_NAMES = ("lo",)


class RecordSource(Protocol):
    def receive(self, timeout: float) -> BusRecord | None: ...


class Limits:
    """When a capture ends: a stop request, a duration, or a number of packets."""

    def __init__(
        self, stop: threading.Event, duration: float | None = None, count: int | None = None
    ) -> None:
        self.stop = stop
        self.deadline = None if duration is None else time.monotonic() + duration
        self.count = count

    def done(self, captured: int) -> bool:
        if self.stop.is_set():
            return True
        if self.count is not None and captured >= self.count:
            return True
        return self.deadline is not None and time.monotonic() >= self.deadline

    def wait(self) -> float:
        if self.deadline is None:
            return POLL_S
        return max(0.0, min(POLL_S, self.deadline - time.monotonic()))


def record_summary(record: BusRecord, clock: Callable[[int], str] | None = None) -> str:
    """One line for the live view of a capture; ``clock`` writes its time (default:
    seconds since the epoch)."""
    kind = record.record_type
    when = clock(record.timestamp_ns) if clock is not None else f"{record.timestamp_ns / 1e9:.6f}"
    stamp = f"{when} g{record.generation}"
    if kind == RecordType.bus_reset:
        return f"{stamp} bus reset, generation {record.generation}"
    if kind == RecordType.ack:
        code = ack_code(record.data[0]) if record.data else 0
        return f"{stamp}   {name_of(AckCode, code)}"
    try:
        if kind == RecordType.phy_packet:
            packet = decode(record.data, crc=record.crc_present, strict=False, kind="phy")
        else:
            packet = decode(record.data, crc=record.crc_present, strict=False, kind="async")
        text = summary(packet)
        if record.crc_placeholder and isinstance(packet, AsyncPacket):
            # Zero CRCs the sender never computed (JHU FPGA over Ethernet) are no error.
            blank: dict[str, Any] = {"header_crc": None}
            if hasattr(packet, "data_crc"):
                blank["data_crc"] = None
            text = summary(replace(packet, **blank)).replace("[no crc]", "[crc not computed]")
    except PacketError as error:
        text = f"unreadable packet ({error}) {record.data.hex()}"
    if record.ack is not None:
        text += f"  {name_of(AckCode, record.ack)}"
    return f"{stamp} {text}"


#: After the COUNTth packet, how long a capture waits for acks still on their way;
#: after a stop request, how long it takes what is still queued.
ACK_GRACE_S = 0.2


def capture_records(
    source: RecordSource,
    writer: PcapngWriter | PcapWriter,
    limits: Limits,
    show: Callable[[str], None] | None = None,
    clock: Callable[[int], str] | None = None,
) -> int:
    """Write records from ``source`` until ``limits`` say stop; returns how many packets.

    ``limits.count`` counts packets, as tshark -c does, not the ack records
    between them; the acks of the last packets still come along, so a count
    never cuts a request or a response from its ack.
    """
    packets = 0
    flushed = time.monotonic()

    def keep(record: BusRecord) -> None:
        tracefile.write_record(writer, record)
        if show is not None:
            show(record_summary(record, clock))

    while not limits.done(packets):
        record = source.receive(limits.wait())
        if record is not None:
            keep(record)
            packets += record.record_type != RecordType.ack
        if time.monotonic() - flushed > FLUSH_S:
            writer.flush()
            flushed = time.monotonic()
    stopped = limits.stop.is_set()
    if stopped or (limits.count is not None and packets >= limits.count):
        # Stopped (Ctrl-C): what reached the tap before is part of the trace, as
        # are the acks of its last packets. Counted: only those acks. Either way
        # for at most a grace time, however busy the bus.
        grace = time.monotonic() + ACK_GRACE_S
        while (left := grace - time.monotonic()) > 0:
            record = source.receive(left)
            if record is None:
                break
            is_packet = record.record_type != RecordType.ack
            if is_packet and not stopped:
                break  # the next packet: past the count
            keep(record)
            packets += is_packet
    writer.flush()
    return packets


class CaptureError(Error, RuntimeError):
    """A capture cannot start (one line for the user)."""


def open_raw_socket(interface: str) -> socket.socket:
    """A packet socket on ``interface`` that sees every frame in both directions."""
    if not hasattr(socket, "AF_PACKET"):
        raise CaptureError("UDP capture needs Linux packet sockets (AF_PACKET)")
    try:
        raw = socket.socket(socket.AF_PACKET, socket.SOCK_RAW, socket.htons(ETH_P_ALL))
    except PermissionError:
        raise CaptureError("UDP capture needs CAP_NET_RAW: run as root or grant it") from None
    try:
        raw.bind((interface, 0))
    except OSError as error:
        raw.close()
        raise CaptureError(f"interface {interface}: {error.strerror or error}") from None
    raw.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 8 << 20)
    return raw


def capture_udp(
    interface: str,
    ports: tuple[int, ...],
    writer: PcapngWriter | PcapWriter,
    limits: Limits,
    show: Callable[[str], None] | None = None,
) -> int:
    """Write every Ethernet frame carrying UDP ``ports`` on ``interface``; returns how many."""
    raw = open_raw_socket(interface)
    decoder = udp.Eth1394Decoder()
    captured = 0
    flushed = time.monotonic()
    try:
        while not limits.done(captured):
            raw.settimeout(max(limits.wait(), 0.01))
            try:
                frame, address = raw.recvfrom(65535)
            except TimeoutError:
                frame = b""
            except InterruptedError:
                continue
            stamp = time.time_ns()
            # On loopback every frame is seen leaving and arriving: keep one copy.
            if frame and not (interface in LOOPBACK_NAMES and address[2] == PACKET_OUTGOING):
                datagram = udp.udp_payload(LINKTYPE_ETHERNET, frame, ports)
                if isinstance(datagram, udp.Datagram):
                    writer.write(stamp, frame)
                    captured += 1
                    if show is not None:
                        show(_datagram_summary(decoder, datagram, stamp))
            if time.monotonic() - flushed > FLUSH_S:
                writer.flush()
                flushed = time.monotonic()
    finally:
        raw.close()
        writer.flush()
    return captured


def _datagram_summary(decoder: udp.Eth1394Decoder, datagram: udp.Datagram, stamp: int) -> str:
    route = f"{datagram.source} -> {datagram.destination}"
    result = decoder.records(datagram, stamp)
    if not isinstance(result, list):
        message = result.message if result is not None else "not Eth1394"
        return f"{stamp / 1e9:.6f} {route} {message}"
    lines = [record_summary(record) for record in result]
    return f"{route} " + " | ".join(lines)
