"""scapy layers generated from the layouts: fw1394 traces and Eth1394 over UDP."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("scapy")

from scapy.compat import raw
from scapy.layers.inet import UDP
from scapy.utils import rdpcap

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import simulate
from fw1394.capture.formats.trace_writer import write_trace
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
