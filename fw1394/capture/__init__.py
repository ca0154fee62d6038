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
"""
