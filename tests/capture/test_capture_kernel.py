"""Linux kernel text: firewire tracepoints and firewire-ohci debug lines."""

from __future__ import annotations

import io
import struct
from pathlib import Path

from fw1394.capture.formats import kernel, kernel_trace, sources
from fw1394.capture.formats.record import BusRecord, Direction, RecordType
from fw1394.capture.views.dissection import Dissection, Options
from fw1394.packets import QuadletReadResponse, QuadletWriteRequest, decode

DATA = Path(__file__).parents[1] / "data"


def records(name: str) -> list[BusRecord]:
    with open(DATA / name, encoding="utf-8") as stream:
        return [b.record(i) for b in kernel.read_batches(stream) for i in range(len(b))]


def run(name: str, view: str) -> str:
    out = io.StringIO()
    path = str(DATA / name)
    Dissection(Options(view=view, workers=1), out).run(sources.jobs(path, sources.detect(path)))
    return out.getvalue()


def test_tracepoint_line_fields() -> None:
    line = (
        "     kworker/3:1-104     [003] .....  2107.432020: async_request_outbound_initiate: "
        "transaction=0xffff8ee1c6b3e000 card_index=0 generation=3 scode=2 dst_id=0xffc0 "
        "tlabel=32 tcode=4 src_id=0xffc1 offset=0xfffff0000400 "
        "header={0xffc08140,0xffc1ffff,0xf0000400,0x0} data={}"
    )
    event = kernel_trace.parse(line)
    assert event is not None and event.transaction == "0xffff8ee1c6b3e000"
    (record,) = event.records
    assert event.time_ns == 2107_432_020_000
    assert record.direction == Direction.outbound and not record.crc_present
    packet = decode(record.data, crc=False)
    assert (packet.tlabel, packet.offset, packet.destination_id) == (32, 0xFFFFF0000400, 0xFFC0)  # type: ignore[union-attr]


def test_tracepoint_data_is_printed_in_cpu_byte_order() -> None:
    # The kernel copies quadlet data from the wire unconverted; x86 prints it swapped.
    wire = 0x31333934
    swapped = struct.unpack("<I", struct.pack(">I", wire))[0]
    line = (
        "<idle>-0 [003] d.h2. 5.000001: async_response_inbound: transaction=0x1 card_index=0 "
        "generation=3 scode=2 status=1 timestamp=0x3c16 dst_id=0xffc1 tlabel=33 tcode=6 "
        f"src_id=0xffc0 rcode=0 header={{0xffc18460,0xffc00000,0x0,{swapped:#x}}} data={{}}"
    )
    event = kernel_trace.parse(line)
    assert event is not None
    packet = decode(event.records[0].data, crc=False)
    assert isinstance(packet, QuadletReadResponse) and packet.quadlet_data == wire
    assert event.records[0].ack == 1  # the ack this node sent back
    big = kernel_trace.parse(line, little_endian=False)
    assert big is not None
    assert decode(big.records[0].data, crc=False).quadlet_data == swapped  # type: ignore[union-attr]


def test_tracepoint_sample_log() -> None:
    found = records("firewire-tracepoints.txt")
    kinds = [r.record_type for r in found]
    assert kinds.count(RecordType.bus_reset) == 2
    # bus_reset_handle lists the self-IDs; self_id_sequence repeats them and is skipped.
    assert kinds.count(RecordType.phy_packet) == 2 + 1 + 2
    requests = [r for r in found if r.record_type == RecordType.async_packet]
    assert requests[0].ack == 2  # from the matching async_request_outbound_complete
    write = next(decode(r.data, crc=False) for r in requests if r.data[3] >> 4 == 0)
    assert isinstance(write, QuadletWriteRequest) and write.quadlet_data == 0x8000
    text = run("firewire-tracepoints.txt", "transactions")
    assert "[BANDWIDTH_AVAILABLE]" in text and "[bus_reset]" in text
    assert "attempts=2 [busy]" in text


def test_rom_is_rebuilt_from_a_tracepoint_log() -> None:
    text = run("firewire-tracepoints.txt", "rom")
    assert "text: 'Linux Firewire'" in text and "text: 'Juju'" in text
    assert "CRC ERROR" not in text and "eui64=0010dc0001234567" in text


def test_ohci_debug_log_from_dmesg() -> None:
    found = records("firewire-ohci-dmesg.txt")
    packets = [r for r in found if r.record_type == RecordType.async_packet]
    assert all(r.partial and not r.crc_present for r in packets)
    assert all(r.time_known for r in found)
    first = decode(packets[0].data, crc=False)
    assert first.offset == 0xFFFFF0000400  # type: ignore[union-attr]
    assert packets[0].ack == 2 and packets[0].direction == Direction.outbound
    # "AR evt_bus_reset" and "2 selfIDs" announce the same reset: one record each.
    assert [r.generation for r in found if r.record_type == RecordType.bus_reset] == [2, 3]
    text = run("firewire-ohci-dmesg.txt", "transactions")
    assert "QR 0xfffff0000400 [config ROM+0x0]  ack_pending -> resp_complete" in text
    assert "[no_ack]" in text and "unsolicited" in text


def test_ohci_log_without_timestamps_has_no_latencies() -> None:
    found = records("firewire-ohci-journal.txt")
    assert found and not any(r.time_known for r in found)
    text = run("firewire-ohci-journal.txt", "transactions")
    assert " us " not in text and "concatenated" in text


def test_broken_firewire_lines_are_reported_with_their_number() -> None:
    text = (
        "[ 1.0] firewire_ohci 0000:05:00.0: AR evt_bus_reset, generation 2\n"
        "     kworker/0:1-1 [000] ..... 9.000000: async_request_inbound: header={0x1} data={}\n"
        "[ 2.0] unrelated line\n"
    )
    (batch,) = list(kernel.read_batches(io.StringIO(text)))
    assert batch.unit == "line" and [issue.position for issue in batch.issues] == [2]
    assert len(batch) == 1
