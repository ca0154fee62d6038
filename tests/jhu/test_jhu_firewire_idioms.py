"""QLA boards on the virtual 1394 bus answer the JHU FireWire host's broadcast idioms.

The library's FireWire port (FirewirePort.cpp; jhu-eth1394.md §3.1 and §3.3 item 7)
never sends a real broadcast: it writes node 0 and relies on every board snooping
what the bus repeats to all nodes:

* the broadcast query: a quadlet write of ``sequence << 16 | board mask`` to node 0
  at 0x1800 (at 0xFFFF_FFFF_000F when no board has firmware 7 or later); every
  board of the mask then broadcasts its block and every hub collects them, so the
  host reads them all from any one board at 0x1000, laid out per §2.10;
* the broadcast write: every board's real-time write block in one block write to
  node 0 at 0xFFFF_FFFF_0000, each board taking the commands tagged with its ID
  (before Rev 8 the ID is in bits 27..24 of each DAC command, §4.6).

The host here is ``fw1394 read``/``write`` through the bus adapter; what it must
find is written below from those sections.
"""

from __future__ import annotations

import json
import subprocess
import sys
import time
from collections.abc import Iterator

import pytest
from bus_support import bus_name

BOARDS = 3
DAC = 1


def fw1394(*args: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", *args], capture_output=True, text=True, timeout=60
    )


@pytest.fixture(params=[4, 7])
def rack(request: pytest.FixtureRequest) -> Iterator[tuple[str, int]]:
    firmware = int(request.param)
    name = bus_name(f"fwidiom{firmware}")
    up = fw1394("bus", "up", "--name", name, "--board", "qla1", "--nodes", str(BOARDS),
                "--firmware", str(firmware), "--heartbeat", "0.05", "--lease", "0.5")  # fmt: skip
    assert up.returncode == 0, up.stderr
    try:
        yield name, firmware
    finally:
        fw1394("bus", "down", "--name", name)


def read(name: str, node: int, offset: int, length: int) -> list[int]:
    done = fw1394("read", "--name", name, str(node), hex(offset), "--length", str(length), "--json")
    assert done.returncode == 0, done.stderr
    data = bytes.fromhex(json.loads(done.stdout)["data"])
    return [int.from_bytes(data[n : n + 4], "big") for n in range(0, len(data), 4)]


def write(name: str, node: int, offset: int, *values: int) -> None:
    extra = ["--block"] if len(values) > 1 else []
    done = fw1394("write", "--name", name, *extra, str(node), hex(offset), *map(hex, values))
    assert done.returncode == 0, done.stderr


def hub_ready(words: list[int], firmware: int, sequence: int) -> bool:
    """Every board's block in the layout of §2.10 for ``firmware``."""
    if firmware < 7:
        slots = [words[17 * board : 17 * board + 17] for board in range(16)]
        return all(
            (slot[0] == sequence << 16 and slot[2] >> 24 == 0x40 | board)
            if board < BOARDS
            else slot == [0] * 17
            for board, slot in enumerate(slots)
        )
    blocks = [words[29 * n : 29 * n + 29] for n in range(BOARDS)]
    return all(
        block[0] >> 16 == sequence and block[2] >> 24 == 0x40 | n for n, block in enumerate(blocks)
    )


@pytest.mark.process
@pytest.mark.slow
def test_query_to_node_0_fills_every_hub(rack: tuple[str, int]) -> None:
    name, firmware = rack
    sequence = 0x0123  # above 255: Rev 4-7 keep the whole 16 bits
    query_offset = 0xFFFF_FFFF_000F if firmware < 7 else 0x1800
    write(name, 0, query_offset, sequence << 16 | (1 << BOARDS) - 1)
    size = 4 * (16 * 17 if firmware < 7 else 29 * BOARDS + 1)
    # The library reads the last board it added; any board's hub holds every block.
    deadline = time.monotonic() + 10
    while True:
        words = read(name, BOARDS - 1, 0x1000, size)
        if hub_ready(words, firmware, sequence) or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    assert hub_ready(words, firmware, sequence), [hex(w) for w in words[:40]]


@pytest.mark.process
@pytest.mark.slow
def test_block_write_to_node_0_reaches_every_board(rack: tuple[str, int]) -> None:
    name, firmware = rack
    words: list[int] = []
    for board in range(BOARDS):
        words += [0x8000_0000 | board << 24 | 0x100 * board + ch for ch in range(1, 5)]
        if firmware == 7:
            words.append(0)  # the control quadlet
    write(name, 0, 0xFFFF_FFFF_0000, *words)
    deadline = time.monotonic() + 10
    expected = {board: [0x100 * board + ch for ch in range(1, 5)] for board in range(BOARDS)}
    while True:
        found = {
            board: [read(name, board, ch << 4 | DAC, 4)[0] & 0xFFFF for ch in range(1, 5)]
            for board in range(BOARDS)
        }
        if found == expected or time.monotonic() > deadline:
            break
        time.sleep(0.1)
    assert found == expected
