"""Capturing and dissecting IEEE 1394 traffic, split by role.

* :mod:`fw1394.capture.formats`: what traces are made of and how they are read and
  written: the record type and fw1394's pcap link layer (``docs/capture-format.md``),
  pcap/pcapng readers and writers, Eth1394 UDP, nosy-dump and kernel text, live
  capture, and :mod:`~fw1394.capture.formats.sources` that opens any of them as
  :class:`~fw1394.capture.formats.batch.Batch` columns;
* :mod:`fw1394.capture.analysis`: the numpy bulk path over those columns: header
  fields, CRCs, transactions, statistics, configuration ROMs;
* :mod:`fw1394.capture.views`: what people see: ``fw1394 dissect``'s rows and plots,
  the Wireshark Lua dissector and the scapy layers, generated from the packet layouts.

Traces are read by :class:`PcapngReader` and :class:`PcapReader` (fw1394's
own link layer and the other containers), written by :class:`PcapngWriter`,
:class:`PcapWriter` and :func:`write_trace`; :class:`BusTap` records a live bus.

Traces are read by :class:`PcapngReader` and :class:`PcapReader` (fw1394's
own link layer and the other containers), written by :class:`PcapngWriter`,
:class:`PcapWriter` and :func:`write_trace`; :class:`BusTap` records a live bus.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Batch": "fw1394.capture.formats.batch",
    "BusRecord": "fw1394.capture.formats.record",
    "BusTap": "fw1394.capture.formats.bus_tap",
    "Direction": "fw1394.capture.formats.record",
    "PcapngReader": "fw1394.capture.formats.pcapng_reader",
    "PcapngWriter": "fw1394.capture.formats.pcap_writer",
    "PcapReader": "fw1394.capture.formats.pcap_reader",
    "PcapWriter": "fw1394.capture.formats.pcap_writer",
    "RecordType": "fw1394.capture.formats.record",
    "write_trace": "fw1394.capture.formats.trace_writer",
}

__all__ = [
    "Batch",
    "BusRecord",
    "BusTap",
    "Direction",
    "PcapReader",
    "PcapWriter",
    "PcapngReader",
    "PcapngWriter",
    "RecordType",
    "write_trace",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.capture.formats.batch import Batch
    from fw1394.capture.formats.bus_tap import BusTap
    from fw1394.capture.formats.pcap_reader import PcapReader
    from fw1394.capture.formats.pcap_writer import PcapngWriter, PcapWriter
    from fw1394.capture.formats.pcapng_reader import PcapngReader
    from fw1394.capture.formats.record import BusRecord, Direction, RecordType
    from fw1394.capture.formats.trace_writer import write_trace
