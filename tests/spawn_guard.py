"""What a test has started: every way a process can begin, recorded.

Imported by the suite's conftest, which fails a test that started a process
without the ``process`` marker (so ``-m "not process"`` starts none).

The wrappers sit on the primitives every higher layer goes through:
``subprocess`` (and ``os.popen``, asyncio's subprocesses) reaches
``_posixsubprocess.fork_exec`` or ``os.posix_spawn``; ``multiprocessing`` (its
pools and ``concurrent.futures``' included) starts a ``BaseProcess``, and its
forkserver and resource tracker reach ``fork_exec`` too; ``os.spawn*`` and
``pty.fork`` reach ``os.fork`` or ``os.forkpty``; ``os.system`` forks in C.
``Popen`` is wrapped as well, for the command in the message.
"""

from __future__ import annotations

import _posixsubprocess
import multiprocessing.process
import os
import subprocess
from collections.abc import Callable, Iterator

import pytest

# What the running test has started, from the start of its setup (module
# fixtures included) to the end of its teardown.
spawned: list[str] = []


def _recording(kind: str, start: Callable[..., object]) -> Callable[..., object]:
    def recorded(*args: object, **kwargs: object) -> object:
        if kind == "subprocess":  # Popen's command follows self
            what: object = kwargs.get("args", args[1:2])
        elif kind == "multiprocessing":
            what = args[:1]
        else:
            what = args[:1] or kwargs
        spawned.append(f"{kind}: {what!r}"[:200])
        return start(*args, **kwargs)

    return recorded


subprocess.Popen.__init__ = _recording("subprocess", subprocess.Popen.__init__)  # type: ignore[method-assign,assignment]
multiprocessing.process.BaseProcess.start = _recording(  # type: ignore[method-assign,assignment]
    "multiprocessing", multiprocessing.process.BaseProcess.start
)
_posixsubprocess.fork_exec = _recording("fork_exec", _posixsubprocess.fork_exec)  # type: ignore[assignment]
for _name in ("fork", "forkpty", "posix_spawn", "posix_spawnp", "system"):
    setattr(os, _name, _recording(_name, getattr(os, _name)))


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    spawned.clear()


@pytest.fixture(autouse=True)
def only_marked_tests_spawn(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a test that started a process but lacks the ``process`` marker.

    ``-m "not process"`` promises a tier that starts no process; this keeps the
    promise true as tests are added.
    """
    yield
    if spawned and request.node.get_closest_marker("process") is None:
        pytest.fail(
            "started a process without @pytest.mark.process: " + "; ".join(spawned[:3]),
            pytrace=False,
        )
