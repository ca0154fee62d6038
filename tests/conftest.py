"""Shared fixtures for the whole suite.

The test tree mirrors the package (``tests/<package>/``). Plain helpers shared by
several packages' tests live beside this file, which pytest puts on the import
path: ``bus_support`` (bus names, node processes, leftovers), ``fake_bus`` (the
membership state machines on a fake medium) and ``polling`` (``wait_until``).
Markers (``process``, ``netns``, ``tshark``, ``iverilog``, ``slow``) are
registered in pyproject.toml; ``-m "not process"`` runs the in-process tiers.
A test that starts a process without the ``process`` marker fails (see
:func:`only_marked_tests_spawn`), so that tier really starts none.
"""

from __future__ import annotations

import multiprocessing.process
import os
import re
import subprocess
from collections.abc import Callable, Iterator
from contextlib import ExitStack
from pathlib import Path

import pytest
from bus_support import LaunchBus, bus_name, stop, wait_until_gone

from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

# What the running test has started: commands of processes, filled by the
# wrappers below from the start of its setup (module fixtures included) to the
# end of its teardown.
_spawned: list[str] = []


def _recording(kind: str, start: Callable[..., object]) -> Callable[..., object]:
    def recorded(*args: object, **kwargs: object) -> object:
        # Popen's command follows self; the others' first argument says enough.
        what = args[1:2] if kind == "subprocess" else args[:1]
        _spawned.append(f"{kind}: {kwargs.get('args', what)!r}"[:200])
        return start(*args, **kwargs)

    return recorded


# Every way the suite can start a process goes through one of these (asyncio's
# subprocesses and concurrent.futures' pools included).
subprocess.Popen.__init__ = _recording("subprocess", subprocess.Popen.__init__)  # type: ignore[method-assign,assignment]
multiprocessing.process.BaseProcess.start = _recording(  # type: ignore[method-assign,assignment]
    "multiprocessing", multiprocessing.process.BaseProcess.start
)
os.fork = _recording("fork", os.fork)  # type: ignore[assignment]
os.system = _recording("system", os.system)  # type: ignore[assignment]


@pytest.hookimpl(tryfirst=True)
def pytest_runtest_setup(item: pytest.Item) -> None:
    _spawned.clear()


@pytest.fixture(autouse=True)
def only_marked_tests_spawn(request: pytest.FixtureRequest) -> Iterator[None]:
    """Fail a test that started a process but lacks the ``process`` marker.

    ``-m "not process"`` promises a tier that starts no process; this keeps the
    promise true as tests are added.
    """
    yield
    if _spawned and request.node.get_closest_marker("process") is None:
        pytest.fail(
            "started a process without @pytest.mark.process: " + "; ".join(_spawned[:3]),
            pytrace=False,
        )


@pytest.fixture
def unique_bus_name(request: pytest.FixtureRequest) -> str:
    """A bus name no other test, and no other test run on this machine, uses."""
    tag = re.sub(r"[^A-Za-z0-9]+", "-", request.node.name.removeprefix("test_"))[:24]
    return bus_name(tag.strip("-") or "bus")


@pytest.fixture
def launch_bus(tmp_path: Path) -> Iterator[LaunchBus]:
    """Start buses of node processes that are members by the time they are returned.

    Every bus is stopped at teardown, even when the test fails, and must leave no
    process behind.
    """
    names: list[str] = []
    with ExitStack() as buses:

        def launch(
            nodes: int,
            *,
            tag: str = "bus",
            board: str = "memory",
            node_arguments: tuple[str, ...] = (),
        ) -> LaunchedBus:
            config = BusConfig(bus_name(tag))
            names.append(config.name)
            bus = LaunchedBus(
                config, nodes, board=board, root=tmp_path, node_arguments=node_arguments
            )
            buses.enter_context(bus)
            bus.wait_members()
            return bus

        yield launch
    for name in names:
        assert wait_until_gone(name) == [], f"processes of bus {name} outlived it"


@pytest.fixture
def node_processes() -> Iterator[list[subprocess.Popen[bytes]]]:
    """Processes a test appends here are stopped at teardown, pass or fail."""
    started: list[subprocess.Popen[bytes]] = []
    yield started
    for process in started:
        stop(process)


@pytest.fixture
def findings_dir(tmp_path: Path) -> Path:
    """An empty directory of its own for a fuzz run's findings."""
    path = tmp_path / "findings"
    path.mkdir()
    return path
