"""Runtime state of buses started in the background: one directory per bus.

``$XDG_RUNTIME_DIR/fw1394/<bus>/`` (or ``/tmp/fw1394-<uid>/<bus>/``) holds
``supervisor.pid`` and ``nodes.json`` (the node processes it started), so that
``fw1394 bus down`` finds every process even if the bus itself is wedged, and
the host adapter's socket ``adapter.sock`` (mode 0600) with ``adapter.pid``.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import time
from dataclasses import asdict, dataclass
from pathlib import Path

from fw1394.transport.config import check_bus_name
from fw1394.transport.procs import process_alive

SUPERVISOR_MODULE = "fw1394.transport.supervisor"


@dataclass(frozen=True, slots=True)
class NodeRecord:
    index: int
    board: str
    board_id: int
    pid: int


def runtime_root() -> Path:
    base = os.environ.get("XDG_RUNTIME_DIR")
    if base and os.path.isdir(base) and os.access(base, os.W_OK):
        return Path(base) / "fw1394"
    return Path(f"/tmp/fw1394-{os.getuid()}")


def bus_dir(name: str, root: Path | None = None) -> Path:
    return (root or runtime_root()) / check_bus_name(name)


def prepare(name: str, root: Path | None = None) -> Path:
    directory = bus_dir(name, root)
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    return directory


def adapter_socket(directory: Path) -> Path:
    """Where the bus's host adapter listens (fw1394.transport.adapter)."""
    return directory / "adapter.sock"


def write_nodes(directory: Path, nodes: list[NodeRecord]) -> None:
    temporary = directory / "nodes.json.tmp"
    temporary.write_text(json.dumps([asdict(n) for n in nodes]))
    temporary.replace(directory / "nodes.json")


def read_nodes(directory: Path) -> list[NodeRecord]:
    try:
        return [NodeRecord(**entry) for entry in json.loads((directory / "nodes.json").read_text())]
    except (FileNotFoundError, ValueError, TypeError):
        return []


def read_pid(directory: Path) -> int | None:
    try:
        return int((directory / "supervisor.pid").read_text())
    except (FileNotFoundError, ValueError):
        return None


def is_ours(pid: int) -> bool:
    """A live process of this package (a recycled pid must never be killed)."""
    if not process_alive(pid):
        return False
    try:
        with open(f"/proc/{pid}/cmdline", "rb") as cmdline:
            return b"fw1394" in cmdline.read()
    except OSError:
        return False


def supervisor_alive(directory: Path) -> int | None:
    pid = read_pid(directory)
    return pid if pid is not None and is_ours(pid) else None


def stop_bus(directory: Path, grace: float = 5.0) -> list[int]:
    """Stop the supervisor and every node it started; the pids that had to be killed."""
    supervisor = supervisor_alive(directory)
    if supervisor is not None:
        os.kill(supervisor, signal.SIGTERM)
        _wait_gone([supervisor], grace)
    leftovers = [n.pid for n in read_nodes(directory) if is_ours(n.pid)]
    if supervisor is not None and is_ours(supervisor):
        leftovers.append(supervisor)
    for pid in leftovers:
        os.kill(pid, signal.SIGKILL)
    _wait_gone(leftovers, grace)
    shutil.rmtree(directory, ignore_errors=True)
    return leftovers


def _wait_gone(pids: list[int], seconds: float) -> None:
    limit = time.monotonic() + seconds
    while any(process_alive(pid) for pid in pids) and time.monotonic() < limit:
        time.sleep(0.02)
