"""What a process of the bus imports before it does anything.

Every node, supervisor, adapter and command is a process of its own, and a
test run starts well over a thousand: a package ``__init__`` that imports its
siblings, or a registry that imports every board's node program, is paid by
each. These start a fresh interpreter (this one has imported everything) and
name the modules that must stay out.
"""

from __future__ import annotations

import json
import subprocess
import sys

import pytest


def _loaded(statement: str, prefixes: tuple[str, ...]) -> list[str]:
    code = (
        f"import json, sys\n{statement}\n"
        f"print(json.dumps(sorted(m for m in sys.modules if m.startswith({prefixes!r}))))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    names: list[str] = json.loads(out.stdout)
    return names


@pytest.mark.process
def test_the_supervisor_imports_no_member_engine_or_packet() -> None:
    # It only starts and stops processes: fw1394.transport's public names stay unloaded
    # (of the packets, only the node-ID vocabulary the bus names use).
    heavy = (
        "fw1394.engine",
        "fw1394.packets.asynchronous",
        "fw1394.packets.layouts",
        "fw1394.transport.bus_host",
        "fw1394.node",
    )
    assert _loaded("import fw1394.transport.supervision.supervisor", heavy) == []


@pytest.mark.process
def test_a_node_imports_the_qla1_ethernet_stack_only_to_run_a_qla1_node() -> None:
    ethernet = ("fw1394.boards.qla1.busnode", "fw1394.boards.qla1.eth_server")
    assert _loaded("import fw1394.node.__main__, fw1394.node.process", ethernet) == []
    statement = (
        "from fw1394.boards.registry import BOARDS\n"
        "BOARDS['qla1'].node_program.check(eth1394=None, firmware=8)"
    )
    assert _loaded(statement, ethernet) == list(ethernet)
