"""The bench's own virtual bus: one board to start with, more for the scale experiment.

Everything started here dies with the bench process: the supervisor and the
added nodes are started with ``--parent-pid`` of this process, and the
supervisor's nodes with its own. Heartbeats are slower than the default
(0.2 s, 3 s lease): with dozens of Python processes on two cores a member
that misses a 1 s lease would churn the bus while it is measured.
"""

from __future__ import annotations

import argparse
import itertools
import os
import shutil
import subprocess
import tempfile
import time
from pathlib import Path

from fw1394.experiments.timing import pin
from fw1394.host.bus_port import BusPort
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.stop import stop
from fw1394.transport.supervision.supervisor import node_command

TIMING = Timing(heartbeat=0.2, lease=3.0)
TIMING_ARGS = ("--heartbeat", "0.2", "--lease", "3.0")
#: A stalled round trip on a loaded machine takes milliseconds; a lost one should not hang.
TRANSACTION_TIMEOUT_S = 1.0
#: After the last join, let the final bus reset and any late heartbeat settle.
SETTLE_S = 0.3
_names = itertools.count()


class PrivateBus:
    """A fresh bus of ``board`` nodes, joined by this process as the host (``port``)."""

    def __init__(self, board: str, *, cpus: set[int] | None = None, timeout: float = 60.0) -> None:
        self.board = board
        self.cpus = cpus
        self.timeout = timeout
        self.config = BusConfig(f"bench{os.getpid()}-{next(_names)}")
        self.root = Path(tempfile.mkdtemp(prefix="fw1394-bench-"))
        self.launched = LaunchedBus(
            self.config, 1, board=board, root=self.root, node_arguments=TIMING_ARGS
        )
        self.added: list[subprocess.Popen[bytes]] = []
        self._port: BusPort | None = None

    def __enter__(self) -> PrivateBus:
        try:
            self.launched.start(self.timeout)
            self.launched.wait_members(timeout=self.timeout)
            self._port = BusPort(
                self.config,
                timing=TIMING,
                ack_timeout=TRANSACTION_TIMEOUT_S,
                split_timeout=TRANSACTION_TIMEOUT_S,
                join_timeout=self.timeout,
            )
            self._place()
            self.wait_for_boards(1)
        except BaseException:
            self.close()
            raise
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def port(self) -> BusPort:
        if self._port is None:
            raise RuntimeError("the bench bus is not up")
        return self._port

    @property
    def boards(self) -> int:
        return 1 + len(self.added)

    def pids(self) -> list[int]:
        supervisor = [] if self.launched.process is None else [self.launched.process.pid]
        nodes = [record.pid for record in self.launched.records()]
        return supervisor + nodes + [process.pid for process in self.added]

    def grow(self, boards: int) -> None:
        """Add node processes until the bus has ``boards`` boards, and wait for them."""
        spec = argparse.Namespace(name=self.config.name, board=self.board)
        while self.boards < boards:
            command = node_command(spec, self.boards, list(TIMING_ARGS))
            self.added.append(subprocess.Popen(command, stdin=subprocess.DEVNULL))
        self._place()
        self.wait_for_boards(boards)

    def wait_for_boards(self, boards: int) -> None:
        port = self.port
        limit = time.monotonic() + self.timeout * max(1.0, boards / 8)
        while len(port.nodes()) < boards:
            if time.monotonic() > limit:
                raise RuntimeError(f"only {len(port.nodes())} of {boards} boards joined the bus")
            port.poll(0.1)
        port.poll(SETTLE_S)

    def _place(self) -> None:
        if self.cpus is not None:
            pin(self.pids(), self.cpus)

    def close(self) -> None:
        if self._port is not None:
            self._port.close()
            self._port = None
        stop(self.added)
        self.added.clear()
        self.launched.stop()
        shutil.rmtree(self.root, ignore_errors=True)
