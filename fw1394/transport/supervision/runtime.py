"""Runtime state of buses: one directory per bus.

``$XDG_RUNTIME_DIR/fw1394/<bus>/`` (or ``/tmp/fw1394-<uid>/<bus>/``; the root is
this user's, mode 0700, or nothing starts: :func:`runtime_root`) holds
``supervisor.pid`` and ``nodes.json`` (the node processes it started), the
bus key (``key``, mode 0600, on a keyed bus), the host adapter's socket
``adapter.sock`` (mode 0600) with ``adapter.pid``, and ``members/``: one small
file per member process of this host, with its pid and the frames it dropped,
so that ``fw1394 bus down`` finds every process, those joined by hand too, even
if the bus itself is wedged, and ``bus status`` can show the drop counts.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import stat
import tempfile
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Protocol

from fw1394.errors import Error
from fw1394.transport.sansio.config import check_bus_name
from fw1394.transport.supervision.procs import process_alive
from fw1394.transport.supervision.stop import GRACE, Pid, stop

if TYPE_CHECKING:
    from fw1394.transport.sansio.wire import MemberInfo


class DropCounts(Protocol):
    """What a member file reports of a seal's drop counts (``seal.DropCounts`` has it).

    Named here, not imported, because the seal finds its key file through this
    module: the dependency runs one way.
    """

    @property
    def forged(self) -> int: ...

    @property
    def replayed(self) -> int: ...

    @property
    def malformed(self) -> int: ...

    @property
    def total(self) -> int: ...

SUPERVISOR_MODULE = "fw1394.transport.supervision.supervisor"
#: The bus key's file in the bus's directory (fw1394.transport.sansio.seal).
KEY_FILE = "key"
MEMBERS_DIR = "members"


@dataclass(frozen=True, slots=True)
class NodeRecord:
    index: int
    board: str
    board_id: int
    pid: int


@dataclass(frozen=True, slots=True)
class MemberRecord:
    """What a member process of this host says about itself in ``members/``."""

    pid: int
    member_id: int
    host: bool
    #: Frames dropped without a valid MAC, and as replays; None on an insecure bus.
    forged: int | None = None
    replayed: int | None = None
    #: Frames dropped as no well-formed frame of their kind (on every bus).
    malformed: int = 0


class MemberFile:
    """This member's file in the bus's runtime directory (``bus down``, ``bus status``)."""

    def __init__(self, bus: str, info: MemberInfo, dropped: DropCounts, *, keyed: bool) -> None:
        self._directory = bus_dir(bus)
        self._info, self._dropped, self._keyed = info, dropped, keyed
        self._path: Path | None = None
        self._written: int | None = None
        self._due = 0.0
        with contextlib.suppress(OSError):
            read_members(self._directory)  # a newcomer clears the files of the dead
        self.update(0.0)

    def update(self, now: float) -> None:
        # Rewritten when the drop counts changed, at most once a second.
        dropped = self._dropped
        total = dropped.total
        if (self._path is not None and total == self._written) or now < self._due:
            return
        self._written, self._due = total, now + 1.0
        info = self._info
        record = MemberRecord(
            info.pid,
            info.member_id,
            info.host,
            dropped.forged if self._keyed else None,
            dropped.replayed if self._keyed else None,
            dropped.malformed,
        )
        with contextlib.suppress(OSError):  # a read-only runtime directory costs only this
            self._path = write_member(self._directory, record)

    def remove(self) -> None:
        if self._path is not None:
            with contextlib.suppress(OSError):
                remove_member(self._path)


class RuntimeRootError(Error, OSError):
    """The runtime root is not a private directory of this user: someone else could
    have made it, or can see or change what is in it."""


def runtime_root() -> Path:
    """Where this user's buses keep their state, checked (see :func:`check_private`).

    ``$XDG_RUNTIME_DIR/fw1394`` when ``XDG_RUNTIME_DIR`` is set (the login
    manager's per-user directory), else ``/tmp/fw1394-<uid>``: a name anyone
    can guess, so whoever made it must be this user, and nobody else may write
    in it or list its bus names.
    """
    base = os.environ.get("XDG_RUNTIME_DIR")
    if not base:
        root = Path(tempfile.gettempdir()) / f"fw1394-{os.getuid()}"
        check_private(root)
        return root
    if not os.path.isdir(base):
        raise RuntimeRootError(f"XDG_RUNTIME_DIR={base} is not a directory")
    check_private(Path(base))  # another user's, after su: not ours to use
    check_private(Path(base) / "fw1394")
    return Path(base) / "fw1394"


def check_private(directory: Path) -> None:
    """Raise :class:`RuntimeRootError` unless ``directory`` is missing or a real
    directory of this user that only this user can enter (mode 0700).

    A directory of this user that others can only read and enter (0755, as
    fw1394 made its root before) is made 0700: nobody else can have put
    anything in it.
    """
    try:
        info = directory.lstat()
    except FileNotFoundError:
        return
    if not stat.S_ISDIR(info.st_mode):
        raise RuntimeRootError(f"runtime directory {directory} is not a directory")
    if info.st_uid != os.getuid():
        raise RuntimeRootError(
            f"runtime directory {directory} belongs to uid {info.st_uid}, not this user "
            f"(uid {os.getuid()}): someone else made it; remove it or set XDG_RUNTIME_DIR"
        )
    mode = stat.S_IMODE(info.st_mode)
    if mode & 0o022:
        raise RuntimeRootError(
            f"runtime directory {directory} has mode {mode:04o}: others can write in it; "
            f"remove it (fw1394 makes it 0700) or set XDG_RUNTIME_DIR"
        )
    if mode & 0o077:
        os.chmod(directory, 0o700)  # ours, unwritable by others: only hide its names


def bus_dir(name: str, root: Path | None = None) -> Path:
    return (root or runtime_root()) / check_bus_name(name)


def prepare(name: str, root: Path | None = None) -> Path:
    """The bus's directory, made if needed (its root too, 0700)."""
    if root is None:
        root = runtime_root()
        with contextlib.suppress(FileExistsError):  # made meanwhile: checked below
            root.mkdir(mode=0o700)
        check_private(root)
    directory = bus_dir(name, root)
    directory.mkdir(parents=True, exist_ok=True, mode=0o700)
    return directory


def adapter_socket(directory: Path) -> Path:
    """Where the bus's host adapter listens (fw1394.transport.host_adapter.server)."""
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


def member_file(directory: Path, record: MemberRecord) -> Path:
    return directory / MEMBERS_DIR / f"{record.pid}-{record.member_id:08x}.json"


def write_member(directory: Path, record: MemberRecord) -> Path:
    """Record (or update) a member process; its file's path."""
    path = member_file(directory, record)
    path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
    temporary = path.with_suffix(".tmp")
    temporary.write_text(json.dumps(asdict(record)))
    temporary.replace(path)
    return path


def remove_member(path: Path) -> None:
    """A member leaves: its file goes, and the directories if nothing else is left."""
    path.unlink(missing_ok=True)
    for directory in (path.parent, path.parent.parent):
        try:
            directory.rmdir()
        except OSError:
            break  # not empty: the bus or another member still uses it


def read_members(directory: Path) -> list[MemberRecord]:
    """The members recorded whose process still runs; the files of the others go.

    A member killed (SIGKILL, a crash) cannot remove its own file: a file whose
    process has exited is removed here, by whoever looks first (``bus status``,
    ``bus down``, a member starting). (A pid handed to another process since
    keeps its file; ``bus down`` stops only processes of this package.)
    """
    records = []
    folder = directory / MEMBERS_DIR
    for path in sorted(folder.glob("*.tmp")):
        if not process_alive(_pid_of(path)):
            path.unlink(missing_ok=True)  # a write its process never finished
    for path in sorted(folder.glob("*.json")):
        try:
            record = MemberRecord(**json.loads(path.read_text()))
        except (OSError, ValueError, TypeError):
            continue
        if process_alive(record.pid):
            records.append(record)
        else:
            path.unlink(missing_ok=True)
    return records


def _pid_of(path: Path) -> int:
    """The pid a member file's name starts with (0: none)."""
    head = path.name.split("-", 1)[0]
    return int(head) if head.isdigit() else 0


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


def stop_bus(directory: Path, grace: float = GRACE) -> list[int]:
    """Stop the supervisor and every node it started; the pids that had to be killed."""
    killed = []
    supervisor = supervisor_alive(directory)
    if supervisor is not None:
        # The supervisor stops its nodes on SIGTERM; nodes it left running are killed.
        killed += stop(Pid(supervisor, is_ours), grace).killed
    nodes = [Pid(n.pid, is_ours) for n in read_nodes(directory)]
    killed += stop(nodes, 0.0, ask=None).killed
    shutil.rmtree(directory, ignore_errors=True)
    return killed


def stop_members(pids: list[int], grace: float = GRACE) -> tuple[list[int], list[int], list[int]]:
    """Stop member processes that no supervisor started (``node run`` by hand).

    SIGTERM (a node leaves the bus cleanly), then SIGKILL after ``grace``; only
    processes of this package. The pids stopped, those that needed SIGKILL, and
    those that could not be stopped (another user's, say).
    """
    ours = [pid for pid in pids if is_ours(pid)]
    outcome = stop([Pid(pid, is_ours) for pid in ours], grace)
    left = outcome.left + [pid for pid in pids if pid not in ours and process_alive(pid)]
    return [pid for pid in ours if pid not in left], outcome.killed, left
