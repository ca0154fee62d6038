"""Starting and stopping a bus of node processes from Python (tests, benchmarks, the CLI)."""

from __future__ import annotations

import os
import subprocess
import sys
import time
from pathlib import Path

from fw1394.errors import Error
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.bus_key import KEY_ENV, KEY_FILE_ENV, write_key
from fw1394.transport.supervision.observe import BusView, watch
from fw1394.transport.supervision.runtime import (
    KEY_FILE,
    SUPERVISOR_MODULE,
    NodeRecord,
    bus_dir,
    prepare,
    read_members,
    read_nodes,
    stop_bus,
    supervisor_alive,
)
from fw1394.transport.supervision.stop import stop


class LaunchError(Error, RuntimeError):
    """The bus did not come up."""


class AlreadyUpError(LaunchError):
    """A bus of that name is already running here; it was left alone."""


class LaunchedBus:
    """A supervisor and its ``nodes`` node processes on bus ``config.name``.

    ``attached=True`` (tests): the supervisor dies with this process, so a test
    that crashes leaves nothing behind. ``attached=False`` (``fw1394 bus up``):
    it runs detached (setsid) until :meth:`stop`.
    """

    def __init__(
        self,
        config: BusConfig,
        nodes: int,
        *,
        board: str = "memory",
        attached: bool = True,
        root: Path | None = None,
        node_arguments: tuple[str, ...] = (),
        log: Path | None = None,
        key: bytes | None = None,
        restart: bool = False,
    ) -> None:
        self.config = config
        self.nodes = nodes
        self.board = board
        self.attached = attached
        self.root = root
        self.node_arguments = node_arguments
        self.log = log
        #: The bus key (``fw1394.transport.sansio.seal``): every node is given it; None: insecure.
        self.key = key
        #: Restart a node process that dies (with back-off), as ``bus up`` does.
        self.restart = restart
        self.directory = bus_dir(config.name, root)
        self.process: subprocess.Popen[bytes] | None = None

    def __enter__(self) -> LaunchedBus:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def command(self) -> list[str]:
        cmd = [
            sys.executable,
            "-m",
            SUPERVISOR_MODULE,
            "--name",
            self.config.name,
            "--nodes",
            str(self.nodes),
            "--board",
            self.board,
            "--interface",
            self.config.interface,
            "--ttl",
            str(self.config.ttl),
        ]
        if self.root is not None:
            cmd += ["--root", str(self.root)]
        if self.attached:
            cmd += ["--parent-pid", str(os.getpid())]
        if self.restart:
            cmd += ["--restart"]
        if self._bus_is_new():
            cmd += ["--new-bus"]
        return cmd + list(self.node_arguments)

    def _bus_is_new(self) -> bool:
        """Nobody can be on the bus: it stays on this host (TTL 0) and none of its
        members runs here. Then its first node need not listen a lease for another
        coordinator; if one appears after all, the two settle it by sort key."""
        return self.config.ttl == 0 and not read_members(bus_dir(self.config.name))

    def start(self, timeout: float = 30.0) -> None:
        if supervisor_alive(self.directory) is not None:
            raise AlreadyUpError(f"bus {self.config.name!r} is already up (fw1394 bus down first)")
        environment = dict(os.environ)
        key_file = prepare(self.config.name, self.root) / KEY_FILE
        if self.key is None:
            key_file.unlink(missing_ok=True)  # a crashed keyed bus's, or none
            environment.pop(KEY_FILE_ENV, None)
            environment.pop(KEY_ENV, None)
        else:
            write_key(key_file, self.key)
            environment[KEY_FILE_ENV] = str(key_file)  # the nodes inherit it
            environment.pop(KEY_ENV, None)
        output = open(self.log, "ab") if self.log else subprocess.DEVNULL  # noqa: SIM115
        try:
            self.process = subprocess.Popen(
                self.command(),
                stdin=subprocess.DEVNULL,
                stdout=output,
                stderr=output,
                start_new_session=not self.attached,
                env=environment,
            )
        finally:
            if self.log:
                output.close()  # type: ignore[union-attr]
        limit = time.monotonic() + timeout
        while len(read_nodes(self.directory)) < self.nodes:
            if self.process.poll() is not None:
                raise LaunchError(f"bus supervisor exited with status {self.process.returncode}")
            if time.monotonic() > limit:
                self.stop()
                raise LaunchError(f"bus {self.config.name!r}: nodes not started in {timeout} s")
            time.sleep(0.02)

    def records(self) -> list[NodeRecord]:
        return read_nodes(self.directory)

    @property
    def member_config(self) -> BusConfig:
        """The configuration a member of this bus needs (its key included)."""
        config = self.config
        return BusConfig(config.name, config.interface, config.ttl, key=self.key or b"")

    def wait_members(self, count: int | None = None, timeout: float = 30.0) -> BusView:
        """The bus view once ``count`` (default: all) node processes are members."""
        want = self.nodes if count is None else count

        def complete(view: BusView) -> bool:
            return sum(1 for m in view.members if not m.host) >= want

        view = watch(self.member_config, timeout, complete)
        if view is None:
            raise LaunchError(
                f"bus {self.config.name!r}: {want} nodes not on the bus in {timeout} s"
            )
        return view

    def stop(self) -> list[int]:
        """Stop everything; the pids that needed SIGKILL (none, normally)."""
        killed = stop_bus(self.directory)
        if self.process is not None:
            # stop_bus asked the supervisor already; this only reaps it (or kills it).
            stop(self.process, ask=None)
        return killed
