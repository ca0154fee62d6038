"""Capturing and dissecting IEEE 1394 traffic.

* :mod:`~fw1394.capture.record`, :mod:`~fw1394.capture.pseudo_header`: the record
  type and fw1394's pcap link layer (``docs/capture-format.md``);
* :mod:`~fw1394.capture.pcapng`, :mod:`~fw1394.capture.tracefile`,
  :mod:`~fw1394.capture.live`: writing traces, capturing a bus or Eth1394 UDP;
* :mod:`~fw1394.capture.sources` and the readers it uses (pcap/pcapng, Eth1394,
  nosy-dump, kernel text): every input as :class:`~fw1394.capture.batch.Batch` columns;
* :mod:`~fw1394.capture.columns`, :mod:`~fw1394.capture.transactions`,
  :mod:`~fw1394.capture.stats`, :mod:`~fw1394.capture.rom`: the numpy bulk path;
* :mod:`~fw1394.capture.engine`: ``fw1394 dissect``;
* :mod:`~fw1394.capture.lua`, :mod:`~fw1394.capture.scapy_layers`: Wireshark and
  scapy, generated from the packet layouts.
"""
