"""What traces are made of and how they are read and written.

The record (:class:`BusRecord`) and its columns (:class:`Batch`), fw1394's pcap
link layer, pcap/pcapng readers and writers, Eth1394 UDP, nosy-dump and kernel
text, live capture and the bus tap. Nothing here imports the analysis or the
views (``lint-imports`` checks it).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Batch": "fw1394.capture.formats.batch",
    "BusRecord": "fw1394.capture.formats.record",
    "BusTap": "fw1394.capture.formats.bus_tap",
    "PcapngReader": "fw1394.capture.formats.pcapng_reader",
    "PcapngWriter": "fw1394.capture.formats.pcap_writer",
    "PcapReader": "fw1394.capture.formats.pcap_reader",
    "PcapWriter": "fw1394.capture.formats.pcap_writer",
    "write_trace": "fw1394.capture.formats.trace_writer",
}

__all__ = [
    "Batch",
    "BusRecord",
    "BusTap",
    "PcapReader",
    "PcapWriter",
    "PcapngReader",
    "PcapngWriter",
    "write_trace",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.capture.formats.batch import Batch
    from fw1394.capture.formats.bus_tap import BusTap
    from fw1394.capture.formats.pcap_reader import PcapReader
    from fw1394.capture.formats.pcap_writer import PcapngWriter, PcapWriter
    from fw1394.capture.formats.pcapng_reader import PcapngReader
    from fw1394.capture.formats.record import BusRecord
    from fw1394.capture.formats.trace_writer import write_trace
