"""The thesis RTL as a board on the virtual bus: `fw1394 read`/`write` against Verilog."""

from __future__ import annotations

import json

import pytest
from bus_support import bus_name, wait_until_gone

from fw1394.capture.formats.bus_tap import BusTap
from fw1394.capture.formats.record import RecordType
from fw1394.cli.main import main
from fw1394.packets import AckCode, BlockReadResponse
from fw1394.packets.asynchronous import decode_async
from fw1394.rtl.simulation import missing_tools

pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
FAST_ARGS = ("--heartbeat", "0.1", "--lease", "2.0")


def test_read_and_write_an_rtl_node_beside_an_emulated_one(
    capsys: pytest.CaptureFixture[str],
) -> None:
    name = bus_name("rtl")
    try:
        up = ["bus", "up", "--name", name, "--nodes", "2", "--board", "rtl:thesis,memory"]
        assert main([*up, *FAST_ARGS, "--timeout", "60"]) == 0
        capsys.readouterr()
        # node 0 is the thesis link in Icarus Verilog, its registers the snake2010 board's
        assert main(["write", "--name", name, "0", "0x3", "0x1234", "--timeout", "2"]) == 0
        assert main(["read", "--name", name, "0", "0x3", "--json", "--timeout", "2"]) == 0
        assert json.loads(capsys.readouterr().out.splitlines()[-1])["data"] == "00001234"
        assert main(["read", "--name", name, "0", "0x4", "--timeout", "2"]) == 0
        assert capsys.readouterr().out.strip() == "00000002"  # FIRMWARE_VERSION
        block = ["read", "--name", name, "0", "0x10", "--length", "8", "--timeout", "2"]
        with BusTap(name, ack_wait=0.5) as tap:  # what a capture records
            assert main(block) == 0
            records = []
            while (record := tap.receive(0.5)) is not None:
                records.append(record)
        assert capsys.readouterr().out.strip() == "00000000 80008000"  # ADC, DAC midpoints
        packets = [r for r in records if r.record_type is RecordType.async_packet]
        request, response = packets[-2], packets[-1]
        assert request.ack == AckCode.ack_pending and response.sender == 0
        answer = decode_async(response.data)  # the bytes the link transmitted, CRCs and all
        assert isinstance(answer, BlockReadResponse) and answer.problems == ()
        assert answer.data == bytes.fromhex("0000000080008000")
        # after a bus reset the link learns its physical ID again from the PHY
        assert main(["bus", "reset", "--name", name]) == 0
        capsys.readouterr()
        assert main(["read", "--name", name, "0", "0x3", "--timeout", "2"]) == 0
        assert capsys.readouterr().out.strip() == "00001234"
        assert main(["read", "--name", name, "1", "0x40", "--timeout", "2"]) == 0
    finally:
        assert main(["bus", "down", "--name", name]) == 0
    assert wait_until_gone(name) == []


def test_a_bad_port_map_is_refused_before_anything_starts(
    capsys: pytest.CaptureFixture[str],
) -> None:
    up = ["bus", "up", "--name", bus_name("x"), "--nodes", "1", "--board", "rtl:nowhere.toml"]
    assert main(up) == 2
    assert "nowhere.toml" in capsys.readouterr().err
