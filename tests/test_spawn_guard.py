"""The suite's guard sees every way a test can start a process.

``-m "not process"`` is only a tier without processes if a test that starts one
unmarked fails; each way of starting one here must be seen by the guard, and an
unmarked test that starts one must fail with the reason.
"""

from __future__ import annotations

import asyncio
import concurrent.futures
import multiprocessing
import os
import pty
import subprocess
import sys
from collections.abc import Callable
from typing import Literal

import pytest
import spawn_guard


def _wait(pid: int) -> None:
    os.waitpid(pid, 0)


def _forked() -> None:
    pid = os.fork()
    if pid == 0:
        os._exit(0)
    _wait(pid)


def _forked_pty() -> None:
    pid, fd = pty.fork()
    if pid == 0:
        os._exit(0)
    os.close(fd)
    _wait(pid)


def _asyncio() -> None:
    async def run() -> None:
        child = await asyncio.create_subprocess_exec("true")
        await child.wait()

    asyncio.run(run())


# Only the fork method: spawn and forkserver leave a helper process (the
# resource tracker, the fork server) running until the worker exits; they start
# their children through BaseProcess.start all the same.
def _multiprocessing(method: Literal["fork"]) -> Callable[[], None]:
    def start() -> None:
        child = multiprocessing.get_context(method).Process(target=int)
        child.start()
        child.join()

    return start


def _pool() -> None:
    context = multiprocessing.get_context("fork")
    with concurrent.futures.ProcessPoolExecutor(1, mp_context=context) as pool:
        assert pool.submit(int, "7").result() == 7


WAYS: dict[str, Callable[[], object]] = {
    "subprocess.run": lambda: subprocess.run(["true"], check=True),
    "subprocess.run, posix_spawn": lambda: subprocess.run(["/bin/true"], close_fds=False),
    "os.popen": lambda: os.popen("true").close(),
    "os.system": lambda: os.system("true"),
    "os.posix_spawn": lambda: _wait(os.posix_spawn("/bin/true", ["true"], os.environ)),
    "os.posix_spawnp": lambda: _wait(os.posix_spawnp("true", ["true"], os.environ)),
    "os.spawnv": lambda: os.spawnv(os.P_WAIT, "/bin/true", ["true"]),
    "os.fork": _forked,
    "pty.fork": _forked_pty,
    "asyncio": _asyncio,
    "multiprocessing fork": _multiprocessing("fork"),
    "ProcessPoolExecutor": _pool,
}


@pytest.mark.process
@pytest.mark.parametrize("start", WAYS.values(), ids=WAYS.keys())
def test_the_guard_sees_a_process_started(start: Callable[[], object]) -> None:
    spawn_guard.spawned.clear()
    start()
    assert spawn_guard.spawned, "started a process unseen"


@pytest.mark.process
def test_an_unmarked_test_that_starts_a_process_fails(pytester: pytest.Pytester) -> None:
    pytester.makeconftest("from spawn_guard import only_marked_tests_spawn, pytest_runtest_setup\n")
    pytester.makepyfile(
        f"""
        import os
        import pytest

        def test_unmarked():
            os.waitpid(os.posix_spawn("/bin/true", ["true"], os.environ), 0)

        @pytest.mark.process
        def test_marked():
            os.waitpid(os.posix_spawn("/bin/true", ["true"], os.environ), 0)

        def test_in_process():
            assert {sys.executable!r}
        """
    )
    result = pytester.runpytest_inprocess("-p", "no:cacheprovider", "-p", "no:xdist")
    result.assert_outcomes(passed=3, errors=1)
    result.stdout.fnmatch_lines(["*started a process without @pytest.mark.process: posix_spawn*"])
