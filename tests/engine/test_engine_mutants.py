"""Two engine behaviours no other test pinned down (found as surviving mutants).

* The planted defect "answers-other-node" takes another node's request as its
  own: the address it answers as keeps the request's bus ID and puts this
  node's physical ID in the low six bits (IEEE 1394 node ID: 10-bit bus ID,
  then 6-bit physical ID). With "source-id-from-request" as well, the response
  carries that address as its source, where the test reads it.
* The loopback's corruption fault flips exactly one bit, anywhere in the
  packet: over many seeds the flipped bits land in every quadlet of a
  20-byte quadlet write request (header, data quadlet, header CRC), not only
  in its first byte.
"""

from __future__ import annotations

import pytest

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Requester
from fw1394.engine.defects import DefectiveResponder
from fw1394.engine.loopback import Faults, Link
from fw1394.engine.policy import POLICIES
from fw1394.packets import QuadletReadRequest, QuadletReadResponse
from fw1394.packets.fast import decode_packet, encode_packet

THIS_NODE = 0xFFC2  # bus 0x3FF (local), physical ID 2


@pytest.mark.parametrize(
    ("policy", "destination", "answered_as"),
    [
        # another node on the local bus: physical ID 5 -> 2
        ("ieee1394", 0xFFC5, 0xFFC2),
        ("thesis", 0xFFC5, 0xFFC2),
        # bus 7, physical ID 5 (a thesis board ignores the bus ID): bus 7, physical ID 2
        ("thesis", 0x01C5, 0x01C2),
        # bus 0x2AA, physical ID 0x2A -> physical ID 2, bus kept
        ("thesis", 0xAAAA, 0xAA82),
    ],
)
def test_a_node_answering_others_answers_as_their_bus_and_its_own_physical_id(
    policy: str, destination: int, answered_as: int
) -> None:
    defects = frozenset({"answers-other-node", "source-id-from-request"})
    node = DefectiveResponder(THIS_NODE, MemorySpace(64), POLICIES[policy], defects=defects)
    request = QuadletReadRequest(destination_id=destination, tlabel=5, source_id=0xFFC0, offset=8)
    reply = node.receive(encode_packet(request), 0.0)
    assert isinstance(reply.response, QuadletReadResponse)
    assert reply.response.source_id == answered_as
    assert reply.response.destination_id == 0xFFC0


def _flipped_bits(seed: int) -> list[int]:
    """Bit positions (0 = the most significant bit of byte 0) where the request a
    corrupting loopback delivered differs from the one the requester sent."""
    requester = Requester(0xFFC1, ack_timeout=0.01, split_timeout=0.01)
    responder = DefectiveResponder(0xFFC0, MemorySpace(64), POLICIES["thesis"])
    link = Link(requester, [responder], faults=Faults(corrupt=1.0), seed=seed)
    requester.write_quadlet(0xFFC0, 4, 0x0123_4567, link.now)
    link.run(until=0.001)
    (sent,) = [e for e in link.trace if e.kind == "request" and "corrupted" in e.faults]
    assert sent.packet is not None
    original = encode_packet(sent.packet)
    assert len(sent.raw) == len(original) == 20
    return [
        8 * index + bit
        for index, (a, b) in enumerate(zip(original, sent.raw, strict=True))
        for bit in range(8)
        if (a ^ b) & (0x80 >> bit)
    ]


def test_the_corruption_fault_flips_one_bit_anywhere_in_the_packet() -> None:
    positions = []
    for seed in range(120):
        flipped = _flipped_bits(seed)
        assert len(flipped) == 1, flipped
        positions += flipped
    assert {position // 32 for position in positions} == {0, 1, 2, 3, 4}  # every quadlet
    assert all(position < 160 for position in positions)


def test_a_corrupted_request_fails_its_crc_check() -> None:
    requester = Requester(0xFFC1)
    link = Link(requester, [], faults=Faults(corrupt=1.0), seed=3)
    requester.read_quadlet(0xFFC0, 0, link.now)
    link.run(until=0.001)
    (sent,) = [e for e in link.trace if e.kind == "request"]
    assert "corrupted" in sent.faults
    assert decode_packet(sent.raw).problems  # the header CRC no longer matches
