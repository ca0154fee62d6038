"""Processes of a bus: starting them, watching them, stopping them, and where they keep state.

* :mod:`~fw1394.transport.supervision.stop`: the one way any child process is stopped.
* :mod:`~fw1394.transport.supervision.procs`: liveness, PID namespaces, dying with the parent.
"""
