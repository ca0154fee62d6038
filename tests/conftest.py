"""Shared fixtures for the whole suite.

The test tree mirrors the package (``tests/<package>/``). Plain helpers shared by
several packages' tests live beside this file, which pytest puts on the import
path: ``bus_support`` (bus names, node processes, leftovers), ``fake_bus`` (the
membership state machines on a fake medium), ``polling`` (``wait_until``) and
``spawn_guard`` (every way a test can start a process, recorded).
Markers (``process``, ``netns``, ``tshark``, ``iverilog``, ``slow``) are
registered in pyproject.toml; ``-m "not process"`` runs the in-process tiers.
A test that starts a process without the ``process`` marker fails (see
:func:`spawn_guard.only_marked_tests_spawn`), so that tier really starts none.
"""

from __future__ import annotations

import compileall
import multiprocessing
import os
import re
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import module_groups
import pytest
from bus_support import LaunchBus, bus_name, stop, wait_until_gone
from hypothesis import HealthCheck, settings

# The guard's fixture and hook, installed for the whole suite.
from spawn_guard import only_marked_tests_spawn as only_marked_tests_spawn
from spawn_guard import pytest_runtest_setup as pytest_runtest_setup

import fw1394
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus

# Hypothesis's per-example deadline and its "too slow" health check are timed
# assertions: on a loaded machine (or under xdist with more processes than
# cores) a 200 ms example fails a property that holds. The properties and their
# example counts stay; only the clock stops deciding. Loaded here, before any
# test module builds its @settings, so those inherit it.
settings.register_profile("suite", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("suite")


def pytest_configure(config: pytest.Config) -> None:
    # pytest-xdist hands tests out in big consecutive chunks, so a worker can be
    # left with several long tests while the other has run dry. One at a time,
    # as workers free up, and the long tests first (below), the run ends about
    # when its longest test does, not later. An explicit --maxschedchunk wins.
    if config.pluginmanager.hasplugin("xdist") and config.getoption("maxschedchunk") is None:
        config.option.maxschedchunk = 1
    # The default --dist load, with one change (module_groups): a module's process
    # tests that share a bus run on one worker. Tests still go out a few at a time
    # as workers free up, long tests first. An explicit --dist other than load wins.
    if (
        config.pluginmanager.hasplugin("xdist")
        and config.getoption("dist") == "load"
        and not hasattr(config, "workerinput")
    ):
        config.option.loadscopereorder = False  # collection order: the long tests first
        _groups.append(tempfile.mkdtemp(prefix="fw1394-groups-"))
    if not hasattr(config, "workerinput"):  # once per run, not once per xdist worker
        _compile_package()
        if config.pluginmanager.hasplugin("xdist") and config.getoption("numprocesses"):
            _rewrite_tests(config)


# Where the xdist workers say which tests go together (empty: no grouping).
_groups: list[str] = []


@pytest.hookimpl(optionalhook=True)
def pytest_configure_node(node: Any) -> None:
    if _groups:
        node.workerinput[module_groups.KEY] = _groups[0]


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_make_scheduler(config: pytest.Config, log: Any) -> Any:
    return module_groups.scheduler(config, _groups[0], log) if _groups else None


@pytest.hookimpl(optionalhook=True)
def pytest_xdist_auto_num_workers(config: pytest.Config) -> int | None:
    """``-n auto``: two workers per CPU, or one when the run starts no process.

    Most of a test that starts processes is waiting for them (bus start-up, leases,
    timeouts, tshark and iverilog runs): with one worker per core, the cores idle
    through those waits. A second worker per core runs another test meanwhile. The
    in-process tests are CPU-bound, so ``-m "not process"`` gets one per core.
    ``PYTEST_XDIST_AUTO_NUM_WORKERS`` still decides when it is set.
    """
    if os.environ.get("PYTEST_XDIST_AUTO_NUM_WORKERS"):
        return None
    cpus = len(os.sched_getaffinity(0))
    in_process_only = "not process" in (config.getoption("markexpr") or "")
    return cpus if in_process_only else 2 * cpus


# __pycache__ directories this run wrote, removed again at its end.
_written: list[Path] = []


def _compile_package() -> None:
    """Compile fw1394's bytecode once for the processes the tests start.

    Under PYTHONDONTWRITEBYTECODE (set in some CI images) no process keeps the
    bytecode it compiles, so every node, adapter and command a test starts (the
    suite starts well over a thousand) compiled each fw1394 module it imports
    again: about a third of its start-up. Compiled here once, they read it. What
    this writes is removed at the end of the run, so the setting still leaves no
    files behind; without the setting Python keeps its bytecode itself.
    """
    if not sys.dont_write_bytecode:
        return
    package = Path(fw1394.__file__).parent
    before = set(package.rglob("__pycache__"))
    compileall.compile_dir(package, quiet=2)
    _written.extend(sorted(set(package.rglob("__pycache__")) - before))


def _rewrite_tests(config: pytest.Config) -> None:
    """Rewrite the test modules' asserts once, for every xdist worker to read.

    Left to themselves, the workers all start together, none finds a rewritten
    module in ``__pycache__`` on a fresh checkout, and each rewrites every one
    (about 4 s of CPU per worker); under PYTHONDONTWRITEBYTECODE they do so on
    every run. pytest reads a rewritten module it finds in ``__pycache__``
    whatever the setting: this writes those that are missing or out of date,
    with pytest's own functions, on every CPU. When those functions are not
    there (another pytest) the workers simply rewrite as before.
    """
    try:
        from _pytest.assertion import rewrite

        config.stash[rewrite.assertstate_key]
        tail = rewrite.PYC_TAIL
    except (ImportError, AttributeError, KeyError):
        return
    here = Path(__file__).parent
    stale = []
    for path in sorted([*here.rglob("test_*.py"), *here.rglob("conftest.py")]):
        cache = rewrite.get_cache_dir(path)
        pyc = cache / (path.name[:-3] + tail)
        if rewrite._read_pyc(path, pyc) is not None:
            continue
        if not cache.exists():
            cache.mkdir()
            if sys.dont_write_bytecode:
                _written.append(cache)
        stale.append((path, pyc))
    global _rewriting
    _rewriting = config
    cpus = len(os.sched_getaffinity(0))
    if cpus > 1 and "fork" in multiprocessing.get_all_start_methods() and len(stale) > cpus:
        with multiprocessing.get_context("fork").Pool(cpus) as pool:
            pool.map(_rewrite_one, stale, chunksize=4)
    else:
        for item in stale:
            _rewrite_one(item)


#: The configuration the test modules are rewritten with (the forked rewriters inherit it).
_rewriting: pytest.Config | None = None


def _rewrite_one(item: tuple[Path, Path]) -> None:
    from _pytest.assertion import rewrite

    path, pyc = item
    assert _rewriting is not None
    try:
        source_hash, code = rewrite._rewrite_test(path, _rewriting)
        rewrite._write_pyc(_rewriting.stash[rewrite.assertstate_key], code, source_hash, pyc)
    except (AttributeError, TypeError, OSError, SyntaxError):
        pass  # another pytest's internals, or a module it will report itself


def pytest_unconfigure(config: pytest.Config) -> None:
    for directory in _written + _groups:
        shutil.rmtree(directory, ignore_errors=True)


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """The ``slow`` tests first, then those that start processes, then the rest.

    Tests that start processes take most of the run and mostly wait; the many
    short in-process tests then fill the end. Each keeps its place in its group.
    """

    def group(item: pytest.Item) -> int:
        if item.get_closest_marker("slow") is not None:
            return 0
        return 1 if item.get_closest_marker("process") is not None else 2

    items.sort(key=group)
    worker = getattr(config, "workerinput", {})
    if module_groups.KEY in worker:
        module_groups.write_groups(worker[module_groups.KEY], worker["workerid"], items)


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
