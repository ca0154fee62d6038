"""Processes of this host: liveness, PID namespaces, dying with the parent."""

from __future__ import annotations

import ctypes
import os
import signal
import zlib
from collections.abc import Callable
from types import FrameType

PR_SET_PDEATHSIG = 1


def process_alive(pid: int) -> bool:
    """Whether ``pid`` runs (a zombie, dead but not yet reaped, counts as gone)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()
    except (FileNotFoundError, ProcessLookupError, IndexError):
        return False
    except PermissionError:
        return True
    return bool(fields) and fields[0] not in (b"Z", b"X")


def process_stopped(pid: int) -> bool:
    """Whether ``pid`` is stopped (SIGSTOP, a terminal's ^Z, a debugger's trace stop)."""
    try:
        with open(f"/proc/{pid}/stat", "rb") as stat:
            fields = stat.read().rsplit(b")", 1)[1].split()
    except (OSError, IndexError):
        return False
    return bool(fields) and fields[0] in (b"T", b"t")


def pid_namespace() -> int:
    """16-bit tag of this process's PID namespace (0 when it cannot be read)."""
    try:
        link = os.readlink("/proc/self/ns/pid")
    except OSError:
        return 0
    return zlib.crc32(link.encode()) & 0xFFFF or 1


def die_with_parent(parent_pid: int, sig: int = signal.SIGTERM) -> None:
    """Have the kernel send ``sig`` to us when our parent exits (Linux).

    Checked against ``parent_pid`` afterwards: a parent that died before the
    call has already handed us to init, and then we must go now.
    """
    # The running program's own symbols include the C library's: no search
    # (ctypes.util.find_library runs ldconfig in a process of its own).
    libc = ctypes.CDLL(None, use_errno=True)
    libc.prctl(PR_SET_PDEATHSIG, sig, 0, 0, 0)
    if os.getppid() != parent_pid:
        os.kill(os.getpid(), sig)


def run_until_signalled(run: Callable[[], None], stop: Callable[[], None]) -> None:
    """``run()`` in the foreground; SIGINT or SIGTERM calls ``stop()`` (which makes it
    return), and the previous handlers come back afterwards."""

    def on_signal(signum: int, frame: FrameType | None) -> None:
        stop()

    previous = {sig: signal.signal(sig, on_signal) for sig in (signal.SIGINT, signal.SIGTERM)}
    try:
        run()
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
