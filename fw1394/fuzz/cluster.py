"""One campaign on a Dask distributed cluster: seeds partitioned, findings merged.

``fw1394 fuzz run TARGET --cluster ADDRESS`` connects to a Dask scheduler and
runs worker ``i``'s share of the campaign (its derived seed and share of
``max_cases``, as :mod:`fw1394.fuzz.workers` does on one machine) as one task
per Dask worker; every task runs an ordinary campaign, shrinking included, on
the machine that runs it, and the reports come back to be merged: counts
added, one finding per signature (the lowest worker's). Dask does the
scheduling, the transport and the failure handling; every machine needs
fw1394 (and, for rtl: targets, Icarus Verilog and cocotb) installed.
"""

from __future__ import annotations

import socket
import time
from typing import Any

from fw1394.fuzz import campaign
from fw1394.fuzz.report import Report
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.fuzz.workers import WORKER, merge, worker_settings


def run(settings: Settings, address: str, *, jobs: int | None = None) -> Report:
    """The campaign of ``settings`` on the cluster at ``address``; the merged report.

    ``jobs``: how many shares (default: one per worker of the cluster).
    """
    try:
        from distributed import Client
    except ImportError:
        raise SettingsError(
            "--cluster needs Dask distributed (pip install 'fw1394[cluster]')"
        ) from None
    if settings.scheme not in ("inproc", "rtl") and WORKER not in settings.target:
        raise SettingsError(
            "--cluster with a remote target needs {worker} in the target (one node per worker)"
        )
    _refuse_early(address)
    try:
        connect: Any = Client  # (distributed ships no type hints)
        client = connect(address, timeout=10)
    except OSError as error:
        raise SettingsError(f"cluster {address}: {error}") from None
    try:
        count = jobs or max(1, len(client.scheduler_info()["workers"]))
        shares = [worker_settings(settings, w, count) for w in range(count)]
        start = time.monotonic()
        futures = client.map(_share, shares, range(count), pure=False)
        reports: list[Report] = client.gather(futures)
    finally:
        client.close()
    report = merge(settings, reports, time.monotonic() - start)
    report.notes.append(f"ran on the Dask cluster at {address}")
    return report


#: Where a Dask scheduler listens unless the address names a port.
SCHEDULER_PORT = 8786


def _refuse_early(address: str) -> None:
    """A TCP address nobody listens on fails now: Dask's client would try again
    until its 10 s timeout. Other schemes (tls://, ws://) are left to Dask."""
    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location, SCHEDULER_PORT)
    except ValueError as error:
        raise SettingsError(f"cluster {address}: {error}") from None
    if scheme != "tcp":
        return
    try:
        socket.create_connection((host, port), timeout=10).close()
    except OSError as error:
        raise SettingsError(f"cluster {address}: {error.strerror or error}") from None


def _share(settings: Settings, worker: int) -> Report:
    # Runs on a Dask worker: an ordinary campaign, shrinking included.
    return campaign.run(settings, worker=worker)
