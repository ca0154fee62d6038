"""Every node's configuration ROM, checked against IEEE 1212 / 1394 as written here.

The layout (bus information block at CSR 0x400, root directory, leaves) and the
CRC-16 are written out from the standards, not taken from fw1394: the CRC is
IEEE 1212's quadlet algorithm (4 bits at a time). On a live bus the ROM is read
through the adapter by quadlet and block reads, by a C program compiled here
against Debian's libraw1394 headers (``raw1394_read`` of 0xFFFFF0000400), and
nodes are found by GUID after one of them was killed and started again.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from adapter_support import NODE_TIMING, adapter_bus
from bus_support import start_node, stop

from fw1394.boards.config_rom import with_config_rom
from fw1394.boards.memory.board import MemorySpace
from fw1394.engine.space import AddressError
from fw1394.host.adapter_port import AdapterPort
from fw1394.host.addressing import BoardNotOnBusError, GuidPort
from fw1394.transport.bus_host import TransactionError

CSR_ROM = 0xFFFF_F000_0400
HEADER = Path("/usr/include/libraw1394/raw1394.h")


def crc16_ieee1212(quadlets: list[int]) -> int:
    """IEEE 1212 CRC-16, the standard's own 4-bits-at-a-time form."""
    crc = 0
    for data in quadlets:
        for shift in range(28, -1, -4):
            total = ((crc >> 12) ^ (data >> shift)) & 0xF
            crc = ((crc << 4) ^ (total << 12) ^ (total << 5) ^ total) & 0xFFFF
    return crc


def text_of(leaf: list[int]) -> str:
    """A textual descriptor leaf (type 0, specifier 0, minimal ASCII) as a string."""
    assert leaf[1] == 0 and leaf[2] == 0
    return b"".join(q.to_bytes(4, "big") for q in leaf[3:]).rstrip(b"\0").decode()


def check_rom(rom: list[int], kind: str) -> int:
    """Check quadlets ``rom`` (from 0x400 on) against the layout; return the GUID."""
    info_length, crc_length, crc = rom[0] >> 24, (rom[0] >> 16) & 0xFF, rom[0] & 0xFFFF
    assert info_length == 4 and crc_length >= info_length
    assert crc == crc16_ieee1212(rom[1 : 1 + crc_length])
    assert rom[1] == 0x31333934  # "1394"
    options = rom[2]
    max_rec, link_speed = (options >> 12) & 0xF, options & 0x7
    assert 1 <= max_rec <= 13 and link_speed <= 2  # S100..S400
    assert (options >> 4) & 0xF == 0  # generation 0: the ROM never changes
    guid = rom[3] << 32 | rom[4]
    # Root directory right after the bus information block.
    root = 1 + info_length
    length = rom[root] >> 16
    entries = rom[root + 1 : root + 1 + length]
    assert rom[root] & 0xFFFF == crc16_ieee1212(entries)
    keys = [entry >> 24 for entry in entries]
    assert 0x03 in keys and 0x0C in keys  # Vendor and Node_Capabilities, immediate
    assert entries[keys.index(0x03)] & 0xFFFFFF == guid >> 40  # node_vendor_ID
    texts = []
    for index, entry in enumerate(entries):
        if entry >> 24 == 0x81:  # textual descriptor leaf: offset from the entry
            leaf = root + 1 + index + (entry & 0xFFFFFF)
            leaf_length = rom[leaf] >> 16
            body = rom[leaf + 1 : leaf + 1 + leaf_length]
            assert rom[leaf] & 0xFFFF == crc16_ieee1212(body)
            texts.append(text_of(rom[leaf : leaf + 1 + leaf_length]))
    assert texts == ["fw1394", kind]
    return guid


def rom_of(space: object, count: int = 24) -> list[int]:
    read = space.read_quadlet  # type: ignore[attr-defined]
    return [read(CSR_ROM + 4 * i) for i in range(count)]


def test_rom_layout_and_crcs_follow_ieee_1212() -> None:
    node = with_config_rom(MemorySpace(4096), bus="lab", board_id=3, rank=3, model="memory")
    guid = check_rom(rom_of(node), "memory")
    assert guid >> 63 == 0 and (guid >> 56) & 0x02  # a locally administered EUI-64
    # A block read is the same bytes; the board behind is untouched and still served.
    block = node.read_block(CSR_ROM, 96)
    assert [int.from_bytes(block[i : i + 4], "big") for i in range(0, 96, 4)] == rom_of(node)
    node.write_quadlet(0x10, 0x12345678)
    assert node.read_quadlet(0x10) == 0x12345678
    with pytest.raises(AddressError):
        node.write_quadlet(CSR_ROM + 8, 0)  # read-only
    with pytest.raises(AddressError):
        node.read_quadlet(CSR_ROM + 2)  # not a quadlet boundary
    assert node.read_quadlet(CSR_ROM + 0x3FC) == 0  # the window past the ROM reads 0


def test_guids_are_unique_per_node_and_stable() -> None:
    def guid(bus: str, board_id: int, rank: int | None) -> int:
        node = with_config_rom(MemorySpace(16), bus=bus, board_id=board_id, rank=rank, model="m")
        return rom_of(node, 5)[3] << 32 | rom_of(node, 5)[4]

    nodes = [(bus, b, r) for bus in ("a", "b") for b in range(4) for r in (0, 1, None)]
    guids = [guid(*node) for node in nodes]
    assert len(set(guids)) == len(nodes)
    assert guids == [guid(*node) for node in nodes]  # the same node, started again


def read_rom(port: AdapterPort, phy: int) -> list[int]:
    return [port.read_quadlet(phy, CSR_ROM + 4 * i) for i in range(24)]


@pytest.mark.process
def test_every_node_of_a_bus_has_a_rom_and_is_found_by_guid() -> None:
    with (
        adapter_bus("rom", 3, board="memory,snake2010,memory") as bus,
        AdapterPort(bus.name, root=bus.root) as port,
    ):
        generation, members = port.table()
        phys = [phy for phy, member in enumerate(members) if not member.host]
        kinds = ["memory", "snake2010", "memory"]
        guids = [
            check_rom(read_rom(port, phy), kind) for phy, kind in zip(phys, kinds, strict=True)
        ]
        assert len(set(guids)) == 3
        block = port.read_block(phys[1], CSR_ROM, 20)
        assert int.from_bytes(block[12:20], "big") == guids[1]
        by_guid = GuidPort(port)
        assert [by_guid.locate(g)[0] for g in guids] == phys
        with pytest.raises(BoardNotOnBusError, match="GUID 0x"):
            by_guid.locate(guids[0] ^ 1)
        # The node of rank 1 killed and started again: the same GUID finds it.
        (record,) = [r for r in bus.bus.records() if r.index == 1]
        os.kill(record.pid, signal.SIGKILL)
        wait_for(lambda: not _locates(by_guid, guids[1]))
        again = start_node(bus.name, 1, "--board", "snake2010", *NODE_TIMING)
        try:
            wait_for(lambda: _locates(by_guid, guids[1]))
            phy, later = by_guid.locate(guids[1])
            assert later > generation
            assert by_guid.port.read_block(phy, CSR_ROM + 12, 8) == guids[1].to_bytes(8, "big")
            cli = bus.fw1394("read", "--guid", hex(guids[1]), hex(CSR_ROM + 16), "--json")
            assert cli.returncode == 0, cli.stderr
            assert json.loads(cli.stdout)["node"] == phy
            missing = bus.fw1394("read", "--guid", hex(guids[1] ^ 1), "0x0")
            assert missing.returncode == 2
            assert missing.stderr.count("\n") == 1 and "Traceback" not in missing.stderr
        finally:
            stop(again)


def _locates(port: GuidPort, guid: int) -> bool:
    """A read by GUID is served (it meets any reset since the last look-up)."""
    try:
        port.read_quadlet(guid, CSR_ROM)
    except (BoardNotOnBusError, TransactionError):
        return False
    return True


def wait_for(condition: object, seconds: float = 30.0) -> None:
    limit = time.monotonic() + seconds
    while not condition():  # type: ignore[operator]
        assert time.monotonic() < limit, "timed out"
        time.sleep(0.05)


EXERCISE = r"""
#include <stdio.h>
#include <arpa/inet.h>
#include <libraw1394/raw1394.h>
int main(void) {
    raw1394handle_t h = raw1394_new_handle();
    if (!h || raw1394_set_port(h, 0) < 0) return 3;
    int local = raw1394_get_local_id(h) & 0x3f, nodes = raw1394_get_nodecount(h);
    for (int n = 0; n < nodes; n++) {
        if (n == local) continue;
        quadlet_t q[5];
        if (raw1394_read(h, 0xffc0 | n, 0xfffff0000400ULL, sizeof q, q) < 0) return 4;
        printf("node %d:", n);
        for (int i = 0; i < 5; i++) printf(" %08x", ntohl(q[i]));
        printf("\n");
    }
    raw1394_destroy_handle(h);
    return 0;
}
"""


@pytest.mark.process
@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
@pytest.mark.skipif(not HEADER.exists(), reason="libraw1394-dev headers are not installed")
def test_libraw1394_program_reads_the_bus_information_blocks(tmp_path: Path) -> None:
    source, program = tmp_path / "rom.c", tmp_path / "rom"
    source.write_text(EXERCISE)
    subprocess.run(["gcc", "-o", str(program), str(source), "-lraw1394"], check=True)
    with adapter_bus("romc", 2, board="memory,snake2010") as bus:
        with AdapterPort(bus.name, root=bus.root) as port:
            expected = [read_rom(port, phy)[:5] for phy in (0, 1)]
        command = [str(Path(sys.executable).with_name("fw1394")), "run", "--name", bus.name]
        result = subprocess.run(
            [*command, "--", str(program)],
            env={**bus.cli_env(), "XDG_CACHE_HOME": str(tmp_path / "cache")},
            capture_output=True,
            text=True,
            timeout=120,
            check=False,
        )
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    seen = [[int(word, 16) for word in line.split(":")[1].split()] for line in lines]
    assert seen == expected
    for info in seen:
        assert info[0] >> 24 == 4 and info[1] == 0x31333934
        assert info[0] & 0xFFFF == crc16_ieee1212(info[1:5])
