"""Byte-exact Eth1394: the captured host requests (jhu-eth1394.md §1.6, §2.10) and the
answers fw1394 boards give them, judged by the real host's own rules (§2.6)."""

from __future__ import annotations

import pytest

from fw1394.boards.qla1.eth_server import Eth1394Server
from fw1394.boards.qla1.ethernet import Reply, datagram
from fw1394.boards.qla1.rack import Rack
from fw1394.jhu.client import SENT_KEPT, EthUdpClient
from fw1394.packets import AsyncPacket, decode
from fw1394.packets.eth1394 import (
    HostReadRequest,
    HostVerdict,
    host_verdict,
    parse_request,
    parse_response,
)
from fw1394.transport.eth1394_addresses import (
    AddressRefusedError,
    Endpoint,
    board_address,
    classful_broadcast,
    multicast_route_check,
    parse_endpoint,
    require_loopback,
)

HOST = ("127.0.0.1", 40000)


def payload(text: str) -> bytes:
    return bytes.fromhex(text.replace(" ", ""))


# (what, UDP payload, no-forward, generation, tl, destination node, tcode)
CAPTURED = [
    ("IP write", "0100 ffff0400 ffd00000 0000000b 0100007f 11c036d8", True, 0, 1, 0x3F, 0),
    ("HW version broadcast", "0100 ffff0840 ffd00000 00000004 58ffb182", True, 0, 2, 0x3F, 4),
    ("HW version node 0", "0105 ffc01c40 ffd00000 00000004 a9927b79", True, 5, 7, 0, 4),
    ("status node 0", "0105 ffc02840 ffd00000 00000000 c0518b0f", True, 5, 10, 0, 4),
    ("RT block read", "0105 ffc09c50 ffd00000 00000000 00800000 fc9a49db", True, 5, 39, 0, 5),
    (
        "RT block write",
        "0105 ffc0a010 ffd00000 00000000 00180000 48855894 00000006 80008000 80008000 "
        "80008000 80008000 00000000 c4d5d450",
        True,
        5,
        40,
        0,
        1,
    ),
    (
        "block write 0x2000",
        "0105 ffc06c10 ffd00000 00002000 000c0000 cca946ca 00000011 00000022 00000033 54289f99",
        True,
        5,
        27,
        0,
        1,
    ),
    ("close relays", "0105 ffff6c00 ffd00000 00000000 00030000 d62f5854", True, 5, 27, 0x3F, 0),
    ("broadcast query", "0105 ffff9c00 ffd00000 00001800 00010001 d1739470", True, 5, 39, 0x3F, 0),
    ("bridge node 1", "0007 ffc13040 ffd00000 00000004 127ae411", False, 7, 12, 1, 4),
    (
        "broadcast write",
        "0105 ffffa410 ffd00000 00000000 00180000 9c5a0a97 00000006 00000000 00000000 "
        "00000000 00000000 00000000 90451703",
        True,
        5,
        41,
        0x3F,
        1,
    ),
    ("hub read fallback", "0105 ffc0a050 ffd00000 00001000 00880000 ddb52355", True, 5, 40, 0, 5),
]


@pytest.mark.parametrize(("what", "text", "no_forward", "gen", "tl", "node", "tcode"), CAPTURED)
def test_captured_requests_decode(
    what: str, text: str, no_forward: bool, gen: int, tl: int, node: int, tcode: int
) -> None:
    request = parse_request(payload(text))
    assert request.control.no_forward is no_forward
    assert request.control.bus_generation == gen
    packet = decode(request.packet)
    assert isinstance(packet, AsyncPacket)
    assert not packet.problems, what  # the host's CRCs are right
    assert int(packet.tcode) == tcode
    assert getattr(packet, "tlabel") == tl  # noqa: B009
    assert getattr(packet, "destination_id") == 0xFFC0 | node  # noqa: B009
    assert getattr(packet, "source_id") == 0xFFD0  # noqa: B009


def answer(rack: Rack, text: str, index: int = 0, now: float = 1.0) -> list[Reply]:
    return [reply for _, reply in rack.receive(index, payload(text), HOST, now)]


def wire(reply: Reply) -> bytes:
    return datagram(reply, reply.received_at, reply.received_at)


def test_quadlet_read_answer_is_the_captured_one() -> None:
    rack = Rack([0], firmware=9)
    rack.bus.generation = 5
    (reply,) = answer(rack, CAPTURED[2][1])
    raw = wire(reply)
    assert len(raw) == 28
    # Exactly the response the real host accepted (zero CRC), then the extra bytes.
    assert raw[:20] == payload("ffd01c60 ffc00000 00000000 514c4131 00000000")
    assert raw[20:24] == bytes([0x10, 0x05, 0, 0])  # no-forward echoed, generation 5
    assert host_verdict(HostReadRequest(0, 7), raw) is HostVerdict.ACCEPTED


def test_every_read_answer_passes_the_host_checks() -> None:
    rack = Rack([0], firmware=9)
    (status,) = answer(rack, CAPTURED[3][1])
    assert host_verdict(HostReadRequest(0, 10), wire(status)) is HostVerdict.ACCEPTED
    assert int.from_bytes(wire(status)[12:16], "big") >> 24 == 0x40  # 4 channels, board 0
    (block,) = answer(rack, CAPTURED[4][1])
    raw = wire(block)
    assert len(raw) == 32 + 128
    assert raw[16:20] == bytes(4) and raw[-12:-8] == bytes(4)  # both CRCs zero
    assert host_verdict(HostReadRequest(0, 39, 128), raw) is HostVerdict.ACCEPTED


def test_writes_get_no_reply_and_take_effect() -> None:
    rack = Rack([0], firmware=9)
    writes = [row for row in CAPTURED if row[6] in (0, 1) and row[0] != "broadcast query"]
    for what, text, *_ in writes:
        assert answer(rack, text) == [], what
    assert rack.members[0].board.ip_register == 0x0100007F  # IP write, board 0 added
    assert rack.members[0].board.read_quadlet(0) & 0x00010000  # relays closed


def test_ethernet_only_broadcast_query_gets_the_unasked_response() -> None:
    rack = Rack([0], firmware=9)
    (reply,) = answer(rack, CAPTURED[8][1])  # query, mask = board 0, sequence 1
    raw = wire(reply)
    assert len(raw) == 32 + 136  # 33 + 1 quadlets for one Rev 9 QLA
    assert host_verdict(HostReadRequest(0x3F, 39, 136), raw) is HostVerdict.ACCEPTED
    assert raw[8:12] == (0x1000).to_bytes(4, "big")  # quadlet 2 of this response
    assert raw[4:6] == b"\xff\xc0"  # from board 0
    header = int.from_bytes(raw[20:24], "big")
    assert header >> 24 == 33 and header >> 16 & 0xFF == 1
    (fallback,) = answer(rack, CAPTURED[11][1], now=1.001)
    assert host_verdict(HostReadRequest(0, 40, 136), wire(fallback)) is HostVerdict.ACCEPTED


def test_bridge_forwards_by_firewire_node_with_real_crcs() -> None:
    rack = Rack([3, 5], firmware=8)
    rack.bus.generation = 7
    (reply,) = answer(rack, CAPTURED[9][1])
    raw = wire(reply)
    assert host_verdict(HostReadRequest(1, 12), raw) is HostVerdict.ACCEPTED
    response = decode(raw[:20])
    assert not response.problems  # a FireWire node's response keeps its CRC
    assert getattr(response, "source_id") == 0xFFC1  # noqa: B009
    assert raw[20] & 0x10 == 0 and raw[21] == 7


def test_generation_mismatch_drops_reads_with_the_extra_only_notice() -> None:
    rack = Rack([3, 5], firmware=8)
    rack.bus.generation = 8  # host still thinks 7
    (reply,) = answer(rack, CAPTURED[9][1])
    raw = wire(reply)
    assert len(raw) == 8 and raw[0] & 0x02 and raw[1] == 8
    assert host_verdict(HostReadRequest(1, 12), raw) is HostVerdict.EXTRA_ONLY
    extra = parse_response(raw).extra
    assert extra.packet_dropped and extra.fpga_bus_generation == 8


def test_foreign_bus_id_is_ignored_and_flagged() -> None:
    rack = Rack([0], firmware=9)
    foreign = "0105 ff801c40 ffd00000 00000004 00000000"  # bus 0x3FE
    assert answer(rack, foreign) == []
    (reply,) = answer(rack, CAPTURED[2][1])
    assert wire(reply)[20] & 0x08  # sticky summary error


def test_crcs_are_not_checked_on_ethernet() -> None:
    rack = Rack([0], firmware=9)
    damaged = CAPTURED[2][1][:-8] + "00000000"
    (reply,) = answer(rack, damaged)
    assert host_verdict(HostReadRequest(0, 7), wire(reply)) is HostVerdict.ACCEPTED


def test_addresses_and_safety_rules() -> None:
    assert board_address("127.0.0.1", 3, 9) == "127.0.0.4"
    assert board_address("127.0.0.1", 3, 8) == "127.0.0.1"
    assert classful_broadcast("127.0.0.1") == "127.255.255.255"
    assert classful_broadcast("169.254.0.100") == "169.254.255.255"
    assert parse_endpoint("127.0.0.2:11394").port == 11394
    with pytest.raises(AddressRefusedError):
        require_loopback("169.254.0.100")
    with pytest.raises(AddressRefusedError):  # refused before any socket is opened
        Eth1394Server(Rack([0]), Endpoint("169.254.0.100", 11394))
    with pytest.raises(AddressRefusedError):
        EthUdpClient(Endpoint("192.168.1.10"))
    header = "Iface\tDestination\tGateway\tFlags\tRefCnt\tUse\tMetric\tMask\tMTU\tWindow\tIRTT\n"
    default = "eth0\t00000000\t010200C0\t0003\t0\t0\t0\t00000000\t0\t0\t0\n"
    on_lo = "lo\t000000E0\t00000000\t0001\t0\t0\t0\t000000F0\t0\t0\t0\n"
    assert multicast_route_check(header + default) is not None
    assert multicast_route_check(header + default + on_lo) is None
    assert multicast_route_check(header) is None  # no route: the host's send just fails


def test_the_client_keeps_only_the_latest_datagrams() -> None:
    # Nothing listens on the discard port: the writes just leave.
    with EthUdpClient(Endpoint("127.0.0.1", 9)) as client:
        for value in range(SENT_KEPT + 3):
            assert client.write_quadlet_node(0, 0, value)
        assert len(client.sent) == SENT_KEPT
        first, last = client.sent[0][1], client.sent[-1][1]
    # The quadlet data sits after the control word and three header quadlets.
    assert int.from_bytes(first[14:18], "big") == 3
    assert int.from_bytes(last[14:18], "big") == SENT_KEPT + 2
