"""No two modules of fw1394 import each other, directly or round a loop.

The layer contracts in pyproject.toml order packages; this orders modules. The
graph is grimp's (the one lint-imports uses), which counts every import: at the
top of a module, inside a function, and under ``if TYPE_CHECKING``.
"""

from __future__ import annotations

import grimp
import pytest


def module_cycles(graph: grimp.ImportGraph) -> set[frozenset[str]]:
    """The strongly connected groups of more than one module (Tarjan, iteratively)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    found: set[frozenset[str]] = set()
    for root in sorted(graph.modules):
        if root in index:
            continue
        work = [(root, iter(sorted(graph.find_modules_directly_imported_by(root))))]
        index[root] = low[root] = len(index)
        stack.append(root)
        on_stack.add(root)
        while work:
            module, edges = work[-1]
            for target in edges:
                if target not in index:
                    index[target] = low[target] = len(index)
                    stack.append(target)
                    on_stack.add(target)
                    work.append(
                        (target, iter(sorted(graph.find_modules_directly_imported_by(target))))
                    )
                    break
                if target in on_stack:
                    low[module] = min(low[module], index[target])
            else:
                work.pop()
                if work:
                    parent = work[-1][0]
                    low[parent] = min(low[parent], low[module])
                if low[module] == index[module]:
                    group = set()
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        group.add(member)
                        if member == module:
                            break
                    if len(group) > 1:
                        found.add(frozenset(group))
    return found


@pytest.fixture(scope="module")
def graph() -> grimp.ImportGraph:
    return grimp.build_graph("fw1394", cache_dir=None)


def test_no_module_cycles(graph: grimp.ImportGraph) -> None:
    # A cycle is broken by moving the piece both modules need below both of them.
    assert sorted(map(sorted, module_cycles(graph))) == []


def test_the_search_finds_a_cycle_through_a_function_level_import() -> None:
    graph = grimp.ImportGraph()
    for module in ("p", "p.a", "p.b", "p.c", "p.d"):
        graph.add_module(module)
    graph.add_import(importer="p.a", imported="p.b")
    graph.add_import(importer="p.b", imported="p.c")
    graph.add_import(importer="p.c", imported="p.a")  # the loop closes
    graph.add_import(importer="p.c", imported="p.d")  # a branch off it
    assert module_cycles(graph) == {frozenset({"p.a", "p.b", "p.c"})}


def test_grimp_counts_function_level_and_type_checking_imports(graph: grimp.ImportGraph) -> None:
    # fw1394.cli.bus imports cli.lsnodes inside a function only, and
    # fw1394.transport.host_adapter.services names the bus host only for typing:
    # a loop through either kind would be found.
    assert "fw1394.cli.lsnodes" in graph.find_modules_directly_imported_by("fw1394.cli.bus")
    imported = graph.find_modules_directly_imported_by("fw1394.transport.host_adapter.services")
    assert "fw1394.transport.bus_host" in imported
