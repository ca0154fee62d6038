"""Media: what carries a bus's frames between its members, and how a member waits for them.

* :mod:`~fw1394.transport.media.choice`: which medium a bus uses (``FW1394_MEDIUM``).
* :mod:`~fw1394.transport.media.udp`: UDP multicast, for a bus on one host or spanning hosts,
  with :mod:`~fw1394.transport.media.bpf`, the kernel filter that plays the link's
  address recognition.
* :mod:`~fw1394.transport.media.shared_memory`: one ring in a file, for members on one host.
* :mod:`~fw1394.transport.media.idle`: waiting for the next frame (block, spin, adaptive).

These modules and the Eth1394 servers and clients are where fw1394 opens sockets.
"""

__all__: list[str] = []
