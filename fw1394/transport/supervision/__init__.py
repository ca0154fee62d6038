"""Processes of a bus: starting them, keeping them, stopping them, and their runtime state.

* :mod:`~fw1394.transport.supervision.launch`: a bus of node processes from Python.
* :mod:`~fw1394.transport.supervision.supervisor`: the process that keeps a background bus.
* :mod:`~fw1394.transport.supervision.runtime`: one directory per bus (pids, member files).
* :mod:`~fw1394.transport.supervision.bus_key`: the bus key in that directory.
* :mod:`~fw1394.transport.supervision.observe`: looking at a bus without joining it.
* :mod:`~fw1394.transport.supervision.stop`: the one way any child process is stopped.
* :mod:`~fw1394.transport.supervision.procs`: liveness, PID namespaces, dying with the parent.
"""

from fw1394.transport.supervision.stop import GRACE, Pid, Stoppable, Stopped, stop

__all__ = ["GRACE", "Pid", "Stoppable", "Stopped", "stop"]
