"""scapy layers generated from the layouts: fw1394 traces and Eth1394 over UDP."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("scapy")

from collections.abc import Iterator
from typing import Any

from adapter_support import AdapterBus, adapter_bus
from hypothesis import given, settings
from hypothesis import strategies as st
from scapy.compat import raw
from scapy.layers.inet import UDP
from scapy.utils import rdpcap

from fw1394 import crc
from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.capture.views import scapy_layers
from fw1394.capture.views.scapy_layers import (
    FW1394,
    Eth1394Request,
    Eth1394Response,
    FW1394Capture,
    FW1394Phy,
)
from fw1394.packets import QuadletReadRequest, RoutedPacket, decode, encode


def test_fw1394_trace_fields(tmp_path: Path) -> None:
    path = tmp_path / "t.pcapng"
    records = list(simulate(30))
    write_trace(str(path), records)
    packets = rdpcap(str(path))
    assert len(packets) == len(records)
    assert FW1394Capture in packets[0] and packets[0][FW1394Capture].record_type == 3
    assert packets[1][FW1394Phy].phy_id == 0
    for packet, record in zip(packets, records, strict=True):
        if FW1394 not in packet:
            continue
        ours = decode(record.data, strict=False)
        assert isinstance(ours, RoutedPacket)
        layer = packet[FW1394]
        assert layer.tlabel == ours.tlabel
        assert layer.dst_id == ours.destination_id
        assert layer.src_id == ours.source_id
        assert layer.header_crc == ours.header_crc
        if hasattr(ours, "offset"):
            assert layer.offset == ours.offset


def test_eth1394_over_udp(tmp_path: Path) -> None:
    path = tmp_path / "eth.pcap"
    write_eth1394_sample(str(path))
    packets = rdpcap(str(path))
    assert packets[0][FW1394].tlabel == 7 and Eth1394Request in packets[0]
    assert packets[0][Eth1394Request].bus_generation == 5
    response = packets[1]
    assert Eth1394Response in response and response[FW1394].quadlet_data == 0x514C4131
    assert response[Eth1394Response].fpga_bus_generation == 5
    assert response[Eth1394Response].total_ticks == 200
    # Building gives back the datagram that was read.
    assert raw(response[UDP].payload) == bytes(response[UDP].payload.original)
    assert packets[4][FW1394].data == bytes.fromhex("000000110000002200000033")


def test_layers_build_wire_packets() -> None:
    wire = encode(QuadletReadRequest(destination_id=0xFFC2, source_id=0xFFC1, tlabel=9, offset=8))
    parsed = FW1394(wire)
    assert parsed.tlabel == 9 and parsed.offset == 8 and raw(parsed) == wire


# -- layers that behave like scapy's own ----------------------------------------------------

KINDS = sorted(scapy_layers.ASYNC_WITH_CRC.items())


def test_each_kind_defaults_to_its_own_tcode() -> None:
    for tcode, layer in KINDS:
        built = raw(layer())
        assert built[3] >> 4 == tcode, layer.__name__  # tcode: bits 7..4 of byte 3
        assert getattr(scapy_layers, layer.__name__) is layer


@st.composite
def layer_values(draw: st.DrawFn) -> tuple[type[FW1394], dict[str, Any]]:
    _, layer = draw(st.sampled_from(KINDS))
    values: dict[str, Any] = {}
    for field in layer.fields_desc:
        if field.name in ("tcode", "header_crc", "data_crc", "data_length", "padding"):
            continue
        if field.name == "data":
            values["data"] = draw(st.binary(max_size=40))
        else:
            values[field.name] = draw(st.integers(0, (1 << field.size) - 1))
    return layer, values


@settings(max_examples=300, deadline=None)
@given(layer_values())
def test_raw_then_parse_round_trips_every_kind(
    case: tuple[type[FW1394], dict[str, Any]],
) -> None:
    layer, values = case
    built = raw(layer(**values))
    parsed = FW1394(built)
    assert type(parsed) is layer
    for name, value in values.items():
        assert getattr(parsed, name) == value, name
    assert raw(parsed) == built
    # The CRCs left None were computed: the spec's CRC-32 over the header quadlets,
    # and over the zero-padded data block.
    header = 4 * layer.header_quadlets
    assert int.from_bytes(built[header : header + 4], "big") == crc.header_crc(built[:header])
    if "data" in values:
        data = values["data"]
        assert isinstance(data, bytes)
        assert parsed.data_length == len(data)
        end = header + 4 + len(crc.padded(data))
        assert built[header + 4 : end] == crc.padded(data)
        assert int.from_bytes(built[end : end + 4], "big") == crc.data_crc(data)


def tcode_of(built: bytes) -> int:
    return built[3] >> 4


def test_a_short_header_is_raw_bytes_not_a_crash() -> None:
    whole = raw(scapy_layers.ASYNC_WITH_CRC[4](dst_id=0xFFC0))
    assert FW1394(whole[:8]).__class__.__name__ == "Raw"


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("scapy", 2, board="memory,qla1") as launched:
        yield launched


@pytest.mark.process
def test_sr1_and_sr_against_a_bus(bus: AdapterBus) -> None:
    """Packets built with their CRCs left None reach the nodes as sound packets.

    The qla1 node's bus info block says "1394" in ASCII in its second quadlet
    (IEEE 1212); the memory node gives back what was written to it."""
    layers = scapy_layers.ASYNC_WITH_CRC
    read, write = layers[4], layers[0]  # read_quadlet_request, write_quadlet_request
    host = 0xFFC2  # the adapter: physical ID 2 after the two nodes
    rom = read(dst_id=0xFFC1, src_id=host, tlabel=5, offset=0xFFFFF0000404)
    answer = scapy_layers.sr1(rom, bus=bus.name, root=bus.root, wait=2.0)
    assert answer.response is not None and answer.response.quadlet_data == 0x31333934
    assert answer.response.tlabel == 5 and answer.response.rcode == 0
    requests = [
        write(dst_id=0xFFC0, src_id=host, tlabel=6, offset=0x100, quadlet_data=0xCAFEF00D),
        read(dst_id=0xFFC0, src_id=host, tlabel=7, offset=0x100),
    ]
    pairs = scapy_layers.sr(requests, bus=bus.name, root=bus.root, wait=2.0)
    assert [sent for sent, _ in pairs] == requests
    write_answer, read_answer = (got for _, got in pairs)
    assert write_answer.ack is not None and write_answer.ack.ack in (1, 2)  # complete, pending
    assert read_answer.response is not None and read_answer.response.quadlet_data == 0xCAFEF00D
    broken = read(dst_id=0xFFC1, src_id=host, tlabel=9, offset=0xFFFFF0000404, header_crc=0)
    assert scapy_layers.sr1(broken, bus=bus.name, root=bus.root, wait=0.5).response is None
