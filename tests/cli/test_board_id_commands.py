"""``fw1394 read|write --board-id``: boards by the ID they announce, whatever their physical ID.

Three memory boards (board IDs 0, 1, 2 at physical IDs 0, 1, 2); killing board 1
renumbers board 2 to physical ID 1, and the commands follow it.
"""

from __future__ import annotations

import json
import os
import signal
from collections.abc import Iterator

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.transport.supervision.observe import watch


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("cliboard", 3) as running:
        yield running


def one_line(result: object) -> str:
    stderr = getattr(result, "stderr", "")
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return str(lines[0])


@pytest.mark.process
def test_usage_errors_are_one_line(bus: AdapterBus) -> None:
    for arguments, blamed in (
        (("read", "--board-id", "1", "0", "0x40"), "OFFSET only"),
        (("read",), "OFFSET"),
        (("write", "0x40", "7"), "NODE"),  # two words: NODE and OFFSET, no value
        (("read", "--board-id", "300", "0x40"), "0..254"),
        (("read", "--board-id", "9", "0x40"), "no board with board ID 9"),
    ):
        result = bus.fw1394(*arguments)
        assert result.returncode == 2 and result.stdout == "", (arguments, result)
        assert blamed in one_line(result), arguments


@pytest.mark.process
def test_a_board_is_followed_across_renumbering(bus: AdapterBus) -> None:
    for board in (0, 1, 2):
        written = bus.fw1394("write", "--board-id", str(board), "0x40", hex(0xB0A0 + board))
        assert written.returncode == 0, written.stderr
        assert f"board ID {board} (node {board})" in written.stdout
    # Physical IDs and board IDs agree so far: the plain command reads the same words.
    assert bus.fw1394("read", "2", "0x40").stdout == "0000b0a2\n"
    before = bus.view().generation
    (victim,) = [r.pid for r in bus.bus.records() if r.board_id == 1]
    os.kill(victim, signal.SIGKILL)
    view = watch(bus.config, 10.0, lambda v: v.generation > before and len(v.members) == 3)
    assert view is not None, "the bus did not drop the killed board"
    result = bus.fw1394("read", "--board-id", "2", "0x40", "--json")
    assert result.returncode == 0, result.stderr
    found = json.loads(result.stdout)
    assert found["board_id"] == 2 and found["node"] == 1 and found["data"] == "0000b0a2"
    assert found["generation"] >= view.generation
    # Physical ID 1 is board 2 now; board 1 is gone.
    assert bus.fw1394("read", "1", "0x40").stdout == "0000b0a2\n"
    gone = bus.fw1394("write", "--board-id", "1", "0x40", "5")
    assert gone.returncode == 2 and "no board with board ID 1" in one_line(gone)
