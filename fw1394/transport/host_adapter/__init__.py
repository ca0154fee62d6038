"""A bus's host adapter: the one host member every program of this machine shares.

* :mod:`~fw1394.transport.host_adapter.server`: the adapter process (``bus up`` starts it)
  and its Unix socket.
* :mod:`~fw1394.transport.host_adapter.protocol`: what clients and the adapter say.
* :mod:`~fw1394.transport.host_adapter.services`: the adapter's answers as a node.
* :mod:`~fw1394.transport.host_adapter.local_node`: that node's registers, sans-IO.
* :mod:`~fw1394.transport.host_adapter.iso`: isochronous channels among the clients.

Clients: :class:`fw1394.host.AdapterPort` and the drop-in libraw1394 (:mod:`fw1394.raw1394`).
"""

__all__: list[str] = []
