"""Writing fw1394 traces: :class:`BusRecord` objects into pcap/pcapng files."""

from __future__ import annotations

import struct
from collections.abc import Iterable

from fw1394.capture.formats import pseudo_header
from fw1394.capture.formats.pcap_writer import PcapngWriter, PcapWriter, open_writer
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.crc import crc32
from fw1394.packets import LAYOUTS, Layout
from fw1394.packets.accessors import TCODE, FieldReader, layout_reader

_QUADLET = struct.Struct(">I")
_LAYOUTS: dict[int, Layout] = {int(tcode): layout for tcode, layout in LAYOUTS.items()}
_DATA_LENGTH: dict[int, FieldReader] = {
    tcode: layout_reader(tcode, "data_length")
    for tcode, layout in _LAYOUTS.items()
    if layout.has_data
}


def crc_ok(record: BusRecord) -> bool:
    """True when every CRC (or the PHY check quadlet) the record carries is right."""
    data = record.data
    if not record.crc_present or record.crc_placeholder:
        return False
    if record.record_type == RecordType.phy_packet:
        if len(data) != 8:
            return False
        quadlet, check = struct.unpack(">II", data)
        return bool(quadlet ^ check == 0xFFFFFFFF)
    if record.record_type != RecordType.async_packet or len(data) < 4:
        return False
    tcode = TCODE.of_bytes(data)
    layout = _LAYOUTS.get(tcode)
    if layout is None:
        return False
    size = layout.header_size
    if len(data) < size + 4 or crc32(data[:size]) != _QUADLET.unpack_from(data, size)[0]:
        return False
    if not layout.has_data:
        return len(data) == size + 4
    length = _DATA_LENGTH[tcode].of_bytes(data)
    padded = (length + 3) & ~3
    end = size + 4 + padded
    if len(data) != end + 4:
        return False
    return bool(crc32(data[size + 4 : end]) == _QUADLET.unpack_from(data, end)[0])


def record_bytes(record: BusRecord) -> bytes:
    """Pseudo-header and packet: one captured packet of the fw1394 link type."""
    return pseudo_header.encode(record, crc_ok(record)) + record.data


def write_record(writer: PcapngWriter | PcapWriter, record: BusRecord) -> None:
    writer.write(record.timestamp_ns, record_bytes(record))


def write_trace(path: str, records: Iterable[BusRecord], container: str = "pcapng") -> int:
    """Write ``records`` to a new trace file; returns how many were written."""
    with open_writer(path, pseudo_header.LINKTYPE_FW1394, container) as writer:
        for record in records:
            write_record(writer, record)
        return writer.packets
