"""Every public vector both ways: decoding gives the source's fields, encoding its bytes."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from fw1394.packets import (
    AsyncPacket,
    ExtendedSelfIdPacket,
    PacketError,
    PhyConfigPacket,
    PhyPacket,
    PortStatus,
    SelfIdPacket,
    decode,
    encode,
    self_id_port_status,
)
from fw1394.packets.asynchronous import decode_async


def decode_async_wire(wire: bytes) -> AsyncPacket:
    packet = decode(wire)
    assert isinstance(packet, AsyncPacket)
    return packet


def decode_phy_quadlet(word: bytes) -> PhyPacket:
    packet = decode(word, crc=False, kind="phy")
    assert isinstance(packet, PhyPacket)
    return packet

VECTORS = Path(__file__).parents[1] / "vectors"
SERDES = json.loads((VECTORS / "linux_packet_serdes_test.json").read_text())["vectors"]
OHCI = json.loads((VECTORS / "linux_ohci_serdes_test.json").read_text())["vectors"]
SELF_ID_SEQUENCES = json.loads((VECTORS / "linux_self_id_sequence_helper_test.json").read_text())[
    "vectors"
]
CAPTURED = json.loads((VECTORS / "jhu_eth1394_captured.json").read_text())

ASYNC = [v for v in SERDES if "header_quadlets_on_wire" in v]
PHY = [v for v in SERDES if v["id"].startswith(("pst-self-id", "pst-phy-config"))]
#: The vectors' short names for kernel fields.
KERNEL_NAMES = {"tl": "tlabel", "rt": "retry", "pri": "priority"}


def raw(text: str) -> bytes:
    return bytes.fromhex("".join(text.split()))


def expected_fields(vector: dict[str, Any]) -> dict[str, int]:
    out = {}
    for key, value in vector["fields"].items():
        if key.endswith("_name"):
            continue
        out[KERNEL_NAMES.get(key, key)] = int(value, 16) if isinstance(value, str) else value
    return out


@pytest.mark.parametrize("vector", ASYNC, ids=lambda v: v["id"])
def test_kernel_headers_decode_to_the_source_fields(vector: dict[str, Any]) -> None:
    words = raw(vector["bytes_hex"])
    header = words[: 4 * vector["header_quadlets_on_wire"]]
    packet = decode_async(header, crc=False)
    fields = expected_fields(vector)
    assert int(packet.tcode) == fields.pop("tcode")
    for name, value in fields.items():
        assert getattr(packet, name) == value, name
    assert packet.header_crc is None and packet.header_crc_ok is None


@pytest.mark.parametrize("vector", ASYNC, ids=lambda v: v["id"])
def test_kernel_headers_encode_to_the_source_bytes(vector: dict[str, Any]) -> None:
    words = raw(vector["bytes_hex"])
    size = 4 * vector["header_quadlets_on_wire"]
    packet = decode_async(words[:size], crc=False)
    # Encoding without CRC reproduces the kernel's header (block payloads are not given).
    assert encode(packet, crc=False)[:size] == words[:size]
    # With CRC, the header CRC is the independently computed CRC-32/BZIP2.
    wire = encode(packet)
    assert wire[size : size + 4] == raw(vector["header_crc_computed"][2:])


@pytest.mark.parametrize(
    "vector", [v for v in ASYNC if "data_length" not in v["fields"]], ids=lambda v: v["id"]
)
def test_whole_wire_packets_round_trip(vector: dict[str, Any]) -> None:
    wire = raw(vector["wire_packet_hex_computed"])
    packet = decode_async_wire(wire)
    assert packet.header_crc_ok
    assert encode(packet) == wire


def test_write_quadlet_header_crc_covers_the_data_quadlet() -> None:
    wire = raw(
        next(v for v in ASYNC if v["id"] == "pst-write-quadlet-request")["wire_packet_hex_computed"]
    )
    broken = wire[:12] + b"\x00\x00\x00\x00" + wire[16:]
    with pytest.raises(PacketError) as error:
        decode(broken)
    assert error.value.field == "header_crc"


@pytest.mark.parametrize("vector", PHY, ids=lambda v: v["id"])
def test_phy_packets(vector: dict[str, Any]) -> None:
    words = raw(vector["bytes_hex"])
    wire = (
        raw(vector["wire_with_inverse_computed"])
        if "wire_with_inverse_computed" in vector
        else None
    )
    fields = vector["fields"]
    packets = [decode_phy_quadlet(words[i : i + 4]) for i in range(0, len(words), 4)]
    first = packets[0]
    if fields.get("packet_identifier_name") == "phy_config":
        assert isinstance(first, PhyConfigPacket)
        for name in ("root_id", "force_root", "gap_count_optimization", "gap_count"):
            assert getattr(first, name) == fields[name], name
    else:
        assert isinstance(first, SelfIdPacket)
        zero = fields.get("packet0", fields)
        assert first.phy_id == fields["phy_id"]
        for name in (
            "link_active",
            "gap_count",
            "scode",
            "contender",
            "power_class",
            "initiated_reset",
            "more_packets",
        ):
            assert getattr(first, name) == zero[name], name
        statuses = [PortStatus[name].value for name in fields["port_status"]]
        assert self_id_port_status(packets)[: len(statuses)] == statuses
        if "packet1" in fields:
            assert isinstance(packets[1], ExtendedSelfIdPacket)
            assert packets[1].sequence == fields["packet1"]["sequence"]
    for packet, offset in zip(packets, range(0, len(words), 4), strict=True):
        assert encode(packet, crc=False) == words[offset : offset + 4]
    if wire is not None:
        for offset in range(0, len(wire), 8):
            pair = wire[offset : offset + 8]
            assert encode(decode(pair)) == pair
            decoded = decode(pair)
            assert isinstance(decoded, PhyPacket)
            assert decoded.inverse_ok


def test_ohci_self_id_buffer_packets() -> None:
    vector = next(v for v in OHCI if v["id"] == "ohci-selfid-receive-buffer")
    words = raw(vector["bytes_hex"])[4:]  # skip the OHCI header quadlet
    for decoded, offset in zip(vector["phy_packets_decoded_by_us"], (0, 8), strict=True):
        packet = decode(words[offset : offset + 8])
        assert isinstance(packet, SelfIdPacket)
        assert packet.inverse_ok
        assert packet.phy_id == decoded["phy_id"]
        assert packet.gap_count == decoded["gap_count"]


def test_self_id_sequence_port_status() -> None:
    vector = next(v for v in SELF_ID_SEQUENCES if v["id"] == "sid-port-status")
    # The source leaves the identifier bits zero (its helper reads port fields only);
    # set them so the quadlets are self-ID packets, leaving every port field as given.
    quadlets = [int(word, 16) | 0x80000000 for word in vector["bytes_hex"].split()]
    packets = [decode_phy_quadlet(q.to_bytes(4, "big")) for q in quadlets]
    expected = [PortStatus[name].value for name in vector["fields"]["port_status"]]
    assert len(expected) == 28  # port 28 is out of range and reads as none
    assert self_id_port_status(packets)[:27] == expected[:27]
    assert expected[27] == PortStatus.none


@pytest.mark.parametrize("vector", CAPTURED["vectors"], ids=lambda v: v["description"])
def test_captured_host_requests(vector: dict[str, Any]) -> None:
    wire = raw(vector["packet_hex"])
    packet = decode_async_wire(wire)
    for name, value in vector["fields"].items():
        if name == "tcode":
            assert int(packet.tcode) == value
        else:
            assert getattr(packet, name) == value, name
    assert packet.header_crc == vector["header_crc"]
    assert encode(packet) == wire
    # Rebuilt from its fields alone (CRCs computed), the packet is the same bytes.
    fields = {k: v for k, v in vector["fields"].items() if k != "tcode"}
    fresh = type(packet)(**fields, **_extra(packet))
    assert encode(fresh) == wire


def _extra(packet: Any) -> dict[str, Any]:
    names = ("quadlet_data", "data_length", "data", "extended_tcode")
    return {n: getattr(packet, n) for n in names if hasattr(packet, n)}


def test_captured_responses() -> None:
    valid, zero_crc = CAPTURED["responses"]
    packet = decode(raw(valid["packet_hex"]))
    assert packet.header_crc_ok and packet.quadlet_data == 0x514C4131  # type: ignore[union-attr]
    # The FPGA's Ethernet path sends a zero CRC: strict decoding rejects it, lenient keeps it.
    with pytest.raises(PacketError):
        decode(raw(zero_crc["packet_hex"]))
    lenient = decode(raw(zero_crc["packet_hex"]), strict=False)
    assert lenient.header_crc_ok is False and lenient.quadlet_data == 0x514C4131  # type: ignore[union-attr]
