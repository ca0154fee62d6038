"""``fw1394 send``, ``bus status``, ``lsnodes`` and explained failures, on a real bus.

One bus of three kinds (qla1, memory, snake2010) and its adapter, driven by
the real commands as subprocesses. Expectations come from the boards'
definitions: the qla1 configuration ROM builder, the responder policies of
the board registry, the 1394 codec.
"""

from __future__ import annotations

import json
import re
from collections.abc import Iterator

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.boards.qla1.config_rom import build_config_rom
from fw1394.node.description import DEFAULT_FIRMWARE
from fw1394.packets import QuadletReadRequest, encode
from fw1394.packets.hextext import quadlets_hex
from fw1394.packets.nodeid import node_id

QLA1, MEMORY, SNAKE = 0, 1, 2


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("cmds", 3, board="qla1,memory,snake2010") as launched:
        yield launched


@pytest.mark.process
def test_bus_status_names_kinds_generation_and_the_adapter(bus: AdapterBus) -> None:
    result = bus.fw1394("bus", "status", "--json")
    assert result.returncode == 0, result.stderr
    rows = [json.loads(line) for line in result.stdout.splitlines()]
    generation = bus.view().generation
    assert [(r["kind"], r["role"]) for r in rows] == [
        ("qla1", "node"),
        ("memory", "node"),
        ("snake2010", "node"),
        (None, "adapter"),
    ]
    assert {r["generation"] for r in rows} == {generation}
    assert rows[-1]["pid"] == bus.adapter_pid
    text = bus.fw1394("bus", "status").stdout.splitlines()
    assert text[1].split() == ["PHY", "ROLE", "KIND", "GEN", "BOARD", "PID", "ADDRESS", "DROPPED"]
    assert text[2].split()[:4] == ["0", "node", "qla1", str(generation)]
    assert text[5].split()[:3] == ["3", "adapter", "-"]


@pytest.mark.process
def test_lsnodes_decodes_the_rom_where_there_is_one(bus: AdapterBus) -> None:
    result = bus.fw1394("lsnodes", "--json")
    assert result.returncode == 0, result.stderr
    rows = {r["phy_id"]: r for r in map(json.loads, result.stdout.splitlines())}
    assert sorted(rows) == [QLA1, MEMORY, SNAKE]  # the adapter is the host, not listed
    # A node's qla1 board is an FPGA version 2 (with Ethernet) running the default firmware.
    rom = build_config_rom(board_id=QLA1, firmware=DEFAULT_FIRMWARE, has_ethernet=True)
    qla1 = rows[QLA1]
    assert qla1["rom"] is True
    # Bus info block quadlets 3 and 4: node vendor ID and chip ID, as one hex string.
    assert qla1["guid"] == f"0x{rom[3]:08x}{rom[4]:08x}"
    assert re.fullmatch(r"0x[0-9a-f]{16}", qla1["guid"])
    assert qla1["vendor"] == "JHU LCSR" and qla1["vendor_id"] == 0xFA610E
    assert qla1["model"] == "FPGA2/QLA"
    # The other boards carry the general ROM every emulated node has: vendor 0x02F139
    # (locally administered), "fw1394", and a GUID of their own under that vendor.
    others = [rows[MEMORY], rows[SNAKE]]
    assert all(r["rom"] is True and r["vendor_id"] == 0x02F139 for r in others)
    assert all(re.fullmatch(r"0x02f139[0-9a-f]{10}", r["guid"]) for r in others)
    assert len({qla1["guid"], *(r["guid"] for r in others)}) == 3
    assert [rows[p]["kind"] for p in (QLA1, MEMORY, SNAKE)] == ["qla1", "memory", "snake2010"]
    text = bus.fw1394("lsnodes").stdout
    assert "JHU LCSR" in text and "FPGA2/QLA" in text
    assert all(r["guid"][2:] in text for r in rows.values())  # the table: 16 digits, no 0x
    assert "no configuration ROM" not in text


@pytest.mark.process
def test_send_prints_ack_and_response(bus: AdapterBus) -> None:
    assert bus.fw1394("write", str(MEMORY), "0x20", "0xfeedf00d").returncode == 0
    request = QuadletReadRequest(destination_id=node_id(MEMORY), tlabel=3, offset=0x20)
    result = bus.fw1394("send", *quadlets_hex(encode(request)).split(), "--json")
    assert result.returncode == 0, result.stderr
    answer = json.loads(result.stdout)
    assert answer["to"] == MEMORY
    assert answer["ack"] == "ack_pending"
    assert answer["response"]["fields"]["tcode_name"] == "read_quadlet_response"
    assert answer["response"]["fields"]["quadlet_data"] == 0xFEEDF00D
    assert answer["response"]["fields"]["tlabel"] == 3
    text = bus.fw1394("send", *quadlets_hex(encode(request)).split()).stdout
    assert "ack:      ack_pending" in text and "data=0xfeedf00d" in text


@pytest.mark.process
def test_send_malformed_packets_and_silence(bus: AdapterBus) -> None:
    request = encode(QuadletReadRequest(destination_id=node_id(QLA1), offset=0xFFFFF0000400))
    bad_crc = request[:12] + bytes(4)
    # The JHU link acks a damaged header ack_data_error; the standard ignores it.
    jhu = json.loads(bus.fw1394("send", bad_crc.hex(), "--json").stdout)
    assert jhu["ack"] == "ack_data_error" and jhu["response"] is None
    memory = json.loads(bus.fw1394("send", bad_crc.hex(), "--to", str(MEMORY), "--json").stdout)
    assert memory["ack"] is None and memory["response"] is None
    assert "header CRC is wrong" in memory["silence"]
    lock = bus.fw1394(
        "send", "--build", "lock_request", "--set", "extended_tcode=3", "--set",
        "data=00000001", "--to", str(SNAKE), "--json",
    )  # fmt: skip
    assert lock.returncode == 0, lock.stderr
    silent = json.loads(lock.stdout)
    assert silent["ack"] is None and silent["sent"]["fields"]["tcode_name"] == "lock_request"
    assert "snake2010" in silent["silence"] and "lock_request" in silent["silence"]


@pytest.mark.process
def test_send_usage_errors_are_one_line(bus: AdapterBus) -> None:
    for arguments in (
        ("send",),
        ("send", "zz"),
        ("send", "ffc0"),
        ("send", "--build", "no_such_packet"),
        ("send", "--build", "read_quadlet_request", "--set", "colour=3"),
    ):
        result = bus.fw1394(*arguments)
        assert result.returncode == 2, arguments
        assert result.stderr.count("\n") == 1 and result.stderr.startswith("fw1394: error: ")


@pytest.mark.process
def test_an_ignored_lock_is_explained(bus: AdapterBus) -> None:
    result = bus.fw1394("lock", str(SNAKE), "0x0", "fetch_add", "1")
    assert result.returncode == 1
    assert result.stderr.count("\n") == 1
    assert "no_ack" in result.stderr
    assert "snake2010 board does not serve lock_request" in result.stderr
    assert "'thesis'" in result.stderr
    as_json = json.loads(bus.fw1394("lock", str(SNAKE), "0x0", "fetch_add", "1", "--json").stdout)
    assert "snake2010" in as_json["error"]["explanation"]
    # A node whose kind serves locks answers; nothing to explain.
    served = bus.fw1394("lock", str(MEMORY), "0x0", "fetch_add", "1")
    assert served.returncode == 0, served.stderr
