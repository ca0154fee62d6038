"""Stopping processes: real children that obey, ignore or already finished the request."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap

import pytest

from fw1394.transport.supervision.procs import process_alive
from fw1394.transport.supervision.stop import Pid, stop

pytestmark = pytest.mark.process

# Each child reports the signals it receives on stdout, so a test sees what was
# asked before the SIGKILL (which no handler sees).
CHILD = textwrap.dedent(
    """
    import signal, sys, time
    mode = sys.argv[1]
    def heard(signum, frame):
        print(signal.Signals(signum).name, flush=True)
        if mode == "obey":
            sys.exit(7)
    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, heard)
    print("ready", flush=True)
    while True:
        time.sleep(0.05)
    """
)


def child(mode: str) -> subprocess.Popen[str]:
    process = subprocess.Popen(
        [sys.executable, "-c", CHILD, mode], stdout=subprocess.PIPE, text=True
    )
    assert process.stdout is not None
    assert process.stdout.readline() == "ready\n"  # its handlers are in place
    return process


def heard(process: subprocess.Popen[str]) -> list[str]:
    assert process.stdout is not None
    lines = process.stdout.read().split()
    process.stdout.close()
    return lines


def reaped(pid: int) -> bool:
    try:
        os.waitpid(pid, os.WNOHANG)
    except ChildProcessError:
        return True
    return False


def test_a_process_that_ignores_sigterm_is_killed_after_the_grace_period() -> None:
    process = child("ignore")
    outcome = stop(process, grace=0.3)
    assert outcome.killed == [process.pid] and outcome.left == []
    assert process.returncode == -signal.SIGKILL
    assert heard(process) == ["SIGTERM"]  # asked first, killed only then
    assert reaped(process.pid)


def test_a_process_that_exits_on_request_is_not_killed() -> None:
    process = child("obey")
    outcome = stop(process, grace=30.0)
    assert outcome.killed == [] and outcome.left == []
    assert process.returncode == 7
    assert heard(process) == ["SIGTERM"]


def test_the_request_may_be_another_signal() -> None:
    process = child("obey")
    stop(process, grace=30.0, ask=signal.SIGINT)
    assert heard(process) == ["SIGINT"]


def test_a_process_already_asked_another_way_gets_no_signal_before_the_kill() -> None:
    process = child("ignore")
    outcome = stop(process, grace=0.2, ask=None)
    assert outcome.killed == [process.pid]
    assert heard(process) == []


def test_a_process_that_already_exited_is_only_reaped() -> None:
    process = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    while process_alive(process.pid):  # a zombie now: dead, not yet reaped
        pass
    outcome = stop(process, grace=30.0)
    assert outcome.killed == [] and outcome.left == []
    assert process.returncode == 3
    assert reaped(process.pid)


def test_a_group_shares_one_grace_period() -> None:
    stubborn, polite = child("ignore"), child("obey")
    outcome = stop([stubborn, polite], grace=0.3)
    assert outcome.killed == [stubborn.pid]
    assert (stubborn.returncode, polite.returncode) == (-signal.SIGKILL, 7)
    assert heard(stubborn) == heard(polite) == ["SIGTERM"]


def orphan(mode: str) -> tuple[int, subprocess.Popen[str]]:
    """A process that is not our child: started by a shell that then exits."""
    shell = subprocess.Popen(
        ["sh", "-c", f'"{sys.executable}" -c "$0" {mode} & echo $!', CHILD],
        stdout=subprocess.PIPE,
        text=True,
    )
    assert shell.stdout is not None
    pid = int(shell.stdout.readline())
    assert shell.stdout.readline() == "ready\n"
    return pid, shell


def test_a_process_that_is_not_our_child_is_stopped_by_pid() -> None:
    pid, shell = orphan("ignore")
    try:
        outcome = stop(Pid(pid), grace=0.3)
        assert outcome.killed == [pid]
        assert not process_alive(pid)
        assert heard(shell) == ["SIGTERM"]  # the orphan shares the shell's stdout
    finally:
        stop(shell, grace=1.0)


def test_a_pid_that_is_no_longer_the_process_meant_is_never_signalled() -> None:
    pid, shell = orphan("obey")
    try:
        outcome = stop(Pid(pid, alive=lambda _: False), grace=0.3)
        assert outcome.killed == [] and outcome.left == []
        assert process_alive(pid)
    finally:
        stop(Pid(pid), grace=5.0)
        stop(shell, grace=1.0)
        assert heard(shell) == ["SIGTERM"]
