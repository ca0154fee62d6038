"""The bus's rules, sans-IO: what members say to each other and how they agree on a bus.

Nothing here opens a socket, maps memory, starts or signals a process: every
module is a pure function of frames and time, so the state machines are
tested without a network and run the same on every medium.

* :mod:`~fw1394.transport.sansio.config`: a bus name -> groups, UDP port, tag.
* :mod:`~fw1394.transport.sansio.wire`: the frame header's fields and the bus-management payloads.
* :mod:`~fw1394.transport.sansio.membership`: bus resets, self-IDs, physical IDs.
* :mod:`~fw1394.transport.sansio.selfid`: the self-ID packets of a chain.
* :mod:`~fw1394.transport.sansio.seal`: sealing and verifying frames, replays.
"""

__all__: list[str] = []
