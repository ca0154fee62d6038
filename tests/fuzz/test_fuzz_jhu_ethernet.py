"""The JHU contract over Eth1394 and the emulated boards' Ethernet path agree.

Both are derived from one description (:mod:`fw1394.boards.qla1.paths` and the
register map's decodings): the firmware checks no CRC on the Ethernet path,
decodes 16 offset bits (0xFFFF_F000_0400 is register space there), never
answers writes and names the board as the source of its answers. A campaign
against a real ``fw1394 jhu serve`` process finds nothing; the same packets fed
to the emulation and to the reference, at the same instants, get the same
answers; late replies are never taken for a later request's.
"""

from __future__ import annotations

import subprocess
import sys
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.qla1.paths import ETHERNET_PATH, FIREWIRE_PATH
from fw1394.boards.qla1.rack import Rack
from fw1394.fuzz.campaign import run
from fw1394.fuzz.contract import CONTRACTS, contract_path
from fw1394.fuzz.reference import Reference
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.trial import wire_of
from fw1394.fuzz.tunnel import Replies
from fw1394.packets import (
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    encode,
)
from fw1394.packets.eth1394 import ControlWord, Eth1394Request, build_request
from fw1394.packets.fast import decode_packet

NODE = 0xFFC0
HOST = ("127.0.0.1", 40000)
ROM = 0xFFFF_F000_0400
PORT = 21960


def reference(path: object = None) -> Reference:
    return Reference("qla1", 0, NODE, CONTRACTS["jhu"], path=contract_path("jhu", path is not None))


def qread(offset: int, *, bad_crc: bool = False, node: int = NODE, tlabel: int = 3) -> bytes:
    raw = bytearray(
        encode(
            QuadletReadRequest(destination_id=node, tlabel=tlabel, offset=offset, source_id=0xFFFE)
        )
    )
    if bad_crc:
        raw[-1] ^= 0xFF
    return bytes(raw)


def test_contract_path_is_the_boards_ethernet_path() -> None:
    assert contract_path("jhu", True) is ETHERNET_PATH
    assert contract_path("jhu", False) is None
    assert contract_path("thesis", True) is None
    assert ETHERNET_PATH.decoding.address(ROM) == 0x000  # MAIN 0x400 aliases STATUS
    assert FIREWIRE_PATH.decoding.address(ROM) == ROM


def test_config_rom_offset_over_ethernet_reads_registers() -> None:
    raw = qread(ROM)
    wire = wire_of(raw)
    over_ethernet, _ = reference(ETHERNET_PATH).expect(wire.packet, wire.damaged, 0.0, raw=raw)
    over_firewire, _ = reference().expect(wire.packet, wire.damaged, 0.0, raw=raw)
    assert isinstance(over_ethernet.response, QuadletReadResponse)
    assert over_ethernet.response.quadlet_data == 0x4000_0000  # STATUS of board 0
    assert isinstance(over_firewire.response, QuadletReadResponse)
    assert over_firewire.response.quadlet_data >> 16 == 0x0404  # the bus-info block


def test_bad_crc_read_is_answered_over_ethernet_only() -> None:
    raw = qread(4, bad_crc=True)
    wire = wire_of(raw)
    assert wire.damaged
    ethernet, _ = reference(ETHERNET_PATH).expect(wire.packet, wire.damaged, 0.0, raw=raw)
    firewire, _ = reference().expect(wire.packet, wire.damaged, 0.0, raw=raw)
    assert isinstance(ethernet.response, QuadletReadResponse)
    assert ethernet.response.quadlet_data == 0x514C4131
    assert firewire.response is None


def test_foreign_bus_is_ignored_over_ethernet() -> None:
    raw = qread(4, node=0x0000)  # bus 0, node 0
    expected, _ = reference(ETHERNET_PATH).expect(None, True, 0.0, raw=raw)
    assert expected.response is None and expected.ack is None


def _request(draw: st.DrawFn) -> bytes:
    kind = draw(st.sampled_from(["qread", "qwrite", "bread", "bwrite"]))
    node = draw(st.sampled_from([0xFFC0, 0xFFFF, 0xFFC1, 0x0000, 0xFFC0]))
    offset = draw(
        st.sampled_from(
            [
                0,
                4,
                0x104,
                0x14,
                0x3,
                ROM,
                ROM + 4,
                0x1800,
                0x1000,
                0x1_0004,
                0x4000,
                0xFFFF_FFFF_0000,
            ]
        )
    )
    tlabel = draw(st.integers(0, 63))
    value = draw(st.sampled_from([0, 0x0003_0000, 0x0000_0F0F, 0x0080_0000, 0xFFFF_FFFF, 7]))
    common: dict[str, Any] = {
        "destination_id": node,
        "tlabel": tlabel,
        "source_id": 0xFFFE,
        "offset": offset,
    }
    if kind == "qread":
        packet = encode(QuadletReadRequest(**common))
    elif kind == "qwrite":
        packet = encode(QuadletWriteRequest(**common, quadlet_data=value))
    elif kind == "bread":
        packet = encode(BlockReadRequest(**common, data_length=4 * draw(st.integers(1, 40))))
    else:
        data = value.to_bytes(4, "big") * draw(st.integers(1, 8))
        packet = encode(BlockWriteRequest(**common, data=data))
    damage = draw(st.sampled_from(["none", "crc", "cut", "longer"]))
    if damage == "crc":
        packet = packet[:-1] + bytes([packet[-1] ^ 1])
    elif damage == "cut":
        packet = packet[: draw(st.integers(4, len(packet) - 1))]
    elif damage == "longer":
        packet += b"\x12\x34"
    return packet


@st.composite
def sequences(draw: st.DrawFn) -> list[bytes]:
    return [_request(draw) for _ in range(draw(st.integers(1, 12)))]


@settings(max_examples=150, deadline=None)
@given(sequences())
def test_emulation_and_contract_answer_alike(packets: list[bytes]) -> None:
    rack = Rack([0], firmware=8)
    model = reference(ETHERNET_PATH)
    for step, raw in enumerate(packets):
        now = 0.001 * step
        payload = build_request(Eth1394Request(ControlWord(no_forward=True), raw))
        served = [decode_packet(reply.packet) for _, reply in rack.receive(0, payload, HOST, now)]
        wire = wire_of(raw)
        expected, _ = model.expect(wire.packet, wire.damaged, now, raw=raw)
        if expected.response is None:
            assert served == [], raw.hex()
            continue
        [answer] = served
        # The Ethernet path sends zero CRCs; everything else must be the same.
        want = expected.response
        assert type(answer) is type(want), raw.hex()
        for name in ("tlabel", "destination_id", "source_id", "rcode"):
            assert getattr(answer, name) == getattr(want, name), (name, raw.hex())
        for name in ("quadlet_data", "data"):
            assert getattr(answer, name, None) == getattr(want, name, None), (name, raw.hex())


def test_a_late_reply_is_not_taken_for_a_later_request() -> None:
    case = qread(4, tlabel=9)
    batch = [wire_of(case), wire_of(qread(4, tlabel=10))]
    replies = Replies(batch)
    # An earlier block read with label 9 answered late: same label, other kind.
    late = encode(BlockReadResponse(destination_id=0xFFFE, tlabel=9, data=bytes(8)))
    replies.on_response(late, acked=False)
    # And an answer for another requester.
    replies.on_response(encode(QuadletReadResponse(destination_id=0xFFC1, tlabel=9)), acked=False)
    assert replies.responses == [None, None]
    assert replies.late == 2
    good = encode(QuadletReadResponse(destination_id=0xFFFE, tlabel=9, quadlet_data=1))
    replies.on_response(good, acked=False)
    assert replies.responses[0] == good


@pytest.mark.process
def test_a_campaign_against_jhu_serve_finds_nothing() -> None:
    server = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "fw1394.cli.main",
            "jhu",
            "serve",
            "--eth1394",
            f"127.0.0.1:{PORT}",
            "--duration",
            "120",
        ],
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        assert server.stderr is not None
        assert "QLA boards" in server.stderr.readline()
        report = run(
            Settings(
                f"udp:127.0.0.1:{PORT}",
                contract="jhu",
                model="qla1",
                eth1394=True,
                max_cases=1500,
                seed=3,
                shrink_budget=0,
            )
        )
    finally:
        server.terminate()
        server.wait(timeout=30)
    assert report.cases == 1500
    assert [f"{f.oracle}:{f.signature}" for f in report.findings] == []
