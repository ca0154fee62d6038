"""The process that keeps a background bus: it starts the node processes and ends them.

Every node is a ``python -m fw1394.node`` process (its options are the node's
description), started with ``--parent-pid`` of the supervisor and asks the
kernel for SIGTERM when the supervisor goes, so stopping (or killing) the
supervisor takes every node with it. Started by a test with ``--parent-pid``
itself, the whole tree goes when the test process goes, however it ends.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import select
import signal
import subprocess
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path
from types import FrameType

from fw1394.transport.supervision.procs import die_with_parent
from fw1394.transport.supervision.runtime import NodeRecord, prepare, write_nodes
from fw1394.transport.supervision.stop import stop

#: The node program: run by module name (the node package sits above the transport).
NODE_MODULE = "fw1394.node"
#: The host adapter program (not imported: it is a process of its own).
ADAPTER_MODULE = "fw1394.transport.host_adapter.server"
#: Board IDs are the 4-bit rotary switch of the thesis boards.
BOARD_ID_MODULUS = 16


def parse_args(argv: list[str]) -> tuple[argparse.Namespace, list[str]]:
    parser = argparse.ArgumentParser(prog="fw1394-bus-supervisor")
    parser.add_argument("--name", required=True)
    parser.add_argument("--nodes", type=int, required=True)
    parser.add_argument("--board", default="memory")
    parser.add_argument("--root", type=Path, default=None)
    parser.add_argument("--parent-pid", type=int, default=None)
    parser.add_argument("--restart", action="store_true", help="restart nodes that die")
    parser.add_argument("--adapter", action="store_true", help="start the bus's host adapter")
    parser.add_argument(
        "--new-bus", action="store_true", help="nobody is on the bus: the first node starts it"
    )
    # Everything else (interface, timing, faults, defects, Ethernet) is passed through
    # to each node as node options.
    return parser.parse_known_args(argv)


def board_of(boards: str, index: int) -> str:
    """Node ``index``'s board kind: ``boards`` is one kind or a comma-separated cycle."""
    kinds = boards.split(",")
    return kinds[index % len(kinds)]


def node_command(args: argparse.Namespace, index: int, passthrough: list[str]) -> list[str]:
    return [
        sys.executable,
        "-m",
        NODE_MODULE,
        "--name",
        args.name,
        "--board",
        board_of(args.board, index),
        "--board-id",
        str(index % BOARD_ID_MODULUS),
        "--rank",
        str(index),
        "--parent-pid",
        str(os.getpid()),
        "--quiet",
        *passthrough,
    ]


def main(argv: list[str]) -> int:
    args, passthrough = parse_args(argv)
    if args.parent_pid is not None:
        die_with_parent(args.parent_pid)
    stopping = False

    def stop(signum: int, frame: FrameType | None) -> None:
        nonlocal stopping
        stopping = True

    signal.signal(signal.SIGTERM, stop)
    signal.signal(signal.SIGINT, stop)
    # A signal writes to this pipe, so the wait below ends at once instead of at
    # the end of its period: every stop of a bus waits for this process.
    wake, wake_write = os.pipe()
    os.set_blocking(wake_write, False)
    signal.set_wakeup_fd(wake_write)
    directory = prepare(args.name, args.root)
    (directory / "supervisor.pid").write_text(str(os.getpid()))
    children: list[subprocess.Popen[bytes]] = []
    records: list[NodeRecord] = []
    try:
        for index in range(args.nodes):
            if stopping:
                break
            # The first node of a new bus starts it at once; the others, and every
            # restart, join the bus that is there.
            first = ["--new-bus"] if args.new_bus and index == 0 else []
            child = subprocess.Popen(node_command(args, index, passthrough) + first)
            children.append(child)
            board = board_of(args.board, index)
            records.append(NodeRecord(index, board, index % BOARD_ID_MODULUS, child.pid))
        write_nodes(directory, records)
        restarts = [Restart() for _ in children]
        commands = [node_command(args, index, passthrough) for index in range(len(children))]
        if args.adapter:  # the bus's shared host node (fw1394.transport.host_adapter.server)
            root = ["--root", str(args.root)] if args.root else []
            adapter = [sys.executable, "-m", ADAPTER_MODULE, "--name", args.name, *root]
            commands.append([*adapter, "--parent-pid", str(os.getpid()), *passthrough])
            children.append(subprocess.Popen(commands[-1]))
            restarts.append(Restart())
        while not stopping:
            if select.select([wake], [], [], 0.1)[0]:
                os.read(wake, 64)
            for index, child in enumerate(children):
                if child.poll() is None or not args.restart or stopping:
                    continue  # reaped; without --restart a dead node stays down
                now = time.monotonic()
                if restarts[index].due(now, child.returncode, index):
                    child = subprocess.Popen(commands[index])
                    children[index] = child
                    if index < len(records):  # a node, not the adapter
                        records[index] = replace(records[index], pid=child.pid)
                        write_nodes(directory, records)
    finally:
        _end(children)
        for name in ("nodes.json", "supervisor.pid"):
            with contextlib.suppress(FileNotFoundError):
                (directory / name).unlink()
    return 0


#: Back-off between restarts of a node that keeps dying: doubling up to the maximum,
#: back to the first after a node stayed up for STABLE seconds.
FIRST_BACKOFF = 0.25
MAX_BACKOFF = 30.0
STABLE = 10.0


@dataclass(slots=True)
class Restart:
    """When a dead node process is started again (systemd's Restart= with back-off)."""

    started: float = field(default_factory=time.monotonic)
    backoff: float = FIRST_BACKOFF / 2
    at: float | None = None

    def due(self, now: float, status: int | None, index: int) -> bool:
        """Whether to start the node now (it died; told once, then waited for)."""
        if self.at is None:
            stable = now - self.started >= STABLE
            self.backoff = FIRST_BACKOFF if stable else min(self.backoff * 2, MAX_BACKOFF)
            self.at = now + self.backoff
            print(
                f"fw1394 bus: node {index} exited (status {status}); "
                f"restarting it in {self.backoff:.2f} s",
                file=sys.stderr,
                flush=True,
            )
        if now < self.at:
            return False
        self.at, self.started = None, now
        return True


def _end(children: list[subprocess.Popen[bytes]]) -> None:
    stop(children)


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
