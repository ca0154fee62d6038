"""Keeping a module's process tests on one pytest-xdist worker.

A module whose process tests share a fixture that outlives one test (a bus of
node processes, scope="module") starts it once per worker that runs any of
them; handed out one by one, they reach every worker. pytest-xdist's own
grouping (``--dist loadgroup``) renames the tests, which pytest 9 no longer
allows, so here each worker writes down which tests go together (it collected
them and knows their fixtures), and the controller's scheduler reads that
before it hands out the first test.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import pytest
from xdist.scheduler.loadscope import LoadScopeScheduling  # type: ignore[import-untyped]

#: Key of the directory the workers write into, in each worker's workerinput.
KEY = "fw1394_module_groups"


def shares_processes(item: pytest.Item) -> bool:
    """A process test that uses a fixture outliving it (a module's bus, say)."""
    if item.get_closest_marker("process") is None:
        return False
    info = getattr(item, "_fixtureinfo", None)
    definitions = getattr(info, "name2fixturedefs", {})
    return any(
        fixture.scope in ("module", "class", "package") and fixture.baseid
        for fixtures in definitions.values()
        for fixture in fixtures
    )


def write_groups(directory: str, worker: str, items: list[pytest.Item]) -> None:
    """This worker's view: test id -> its module, for the tests kept together."""
    groups = {
        item.nodeid: item.nodeid.split("::", 1)[0] for item in items if shares_processes(item)
    }
    path = Path(directory) / f"{worker}.json"
    path.with_suffix(".part").write_text(json.dumps(groups))
    os.replace(path.with_suffix(".part"), path)


class ModuleGroups(LoadScopeScheduling):  # type: ignore[misc]
    """Tests one at a time, in collection order, but a module's grouped tests as one unit."""

    def __init__(self, config: pytest.Config, directory: str, log: Any = None) -> None:
        super().__init__(config, log)
        self.directory = Path(directory)
        self.groups: dict[str, str] | None = None

    def _split_scope(self, nodeid: str) -> str:
        if self.groups is None:  # every worker has collected by the first call
            self.groups = {}
            for path in self.directory.glob("*.json"):
                self.groups.update(json.loads(path.read_text()))
        return self.groups.get(nodeid, nodeid)
