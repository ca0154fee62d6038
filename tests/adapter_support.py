"""Buses with a host adapter, as ``fw1394 bus up`` starts them, for tests.

The runtime directory is a short private directory (a Unix socket path has at
most 107 bytes), and :func:`cli_env` points ``fw1394`` subprocesses at it.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from bus_support import bus_name, wait_until_gone

from fw1394.transport.host_adapter.server import adapter_pid, wait_adapter
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.observe import BusView, watch

#: Node timing that tolerates a loaded machine.
NODE_TIMING = ("--heartbeat", "0.1", "--lease", "2.0")


@contextmanager
def adapter_bus(
    tag: str, nodes: int, board: str = "memory", node_options: tuple[str, ...] = ()
) -> Iterator[AdapterBus]:
    """A bus of ``nodes`` node processes and its adapter, stopped at the end.

    ``node_options`` go to every node (``--loss 0.05``, say); the adapter ignores them."""
    runtime = Path(tempfile.mkdtemp(prefix="fw"))
    config = BusConfig(bus_name(tag))
    # Every member's runtime files (members/) under the test's root, this process's
    # hosts and the bus's nodes alike, so that they go with it.
    outer = os.environ.get("XDG_RUNTIME_DIR")
    os.environ["XDG_RUNTIME_DIR"] = str(runtime)
    bus = LaunchedBus(
        config,
        nodes,
        board=board,
        root=runtime / "fw1394",
        node_arguments=(*NODE_TIMING, *node_options, "--adapter"),
    )
    try:
        with bus:
            bus.wait_members()
            if wait_adapter(config, bus.directory, 30.0) is None:
                raise RuntimeError(f"the adapter of bus {config.name} did not come up")
            ready = AdapterBus(bus, runtime)
            # A beacon sent before the adapter's join may still be on its way: tests
            # compare generations, so they start from one the adapter is part of.
            limit = time.monotonic() + 30.0
            while ready.adapter_pid not in {m.pid for m in ready.view().members}:
                if time.monotonic() > limit:
                    raise RuntimeError(f"no beacon of bus {config.name} lists its adapter")
            yield ready
        assert wait_until_gone(config.name) == [], f"processes of bus {config.name} outlived it"
    finally:
        if outer is None:
            os.environ.pop("XDG_RUNTIME_DIR", None)
        else:
            os.environ["XDG_RUNTIME_DIR"] = outer
        shutil.rmtree(runtime, ignore_errors=True)


class AdapterBus:
    def __init__(self, bus: LaunchedBus, runtime: Path) -> None:
        self.bus = bus
        self.runtime = runtime
        self.config = bus.config
        self.name = bus.config.name
        self.root = runtime / "fw1394"
        self.directory = bus.directory

    @property
    def adapter_pid(self) -> int | None:
        return adapter_pid(self.directory)

    def view(self) -> BusView:
        view = watch(self.config, 5.0)
        assert view is not None, "no beacon from the bus"
        return view

    def cli_env(self) -> dict[str, str]:
        return {**os.environ, "XDG_RUNTIME_DIR": str(self.runtime)}

    def fw1394(self, *arguments: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            [sys.executable, "-m", "fw1394.cli.main", *arguments, "--name", self.name],
            capture_output=True,
            text=True,
            timeout=timeout,
            env=self.cli_env(),
            stdin=subprocess.DEVNULL,
        )
