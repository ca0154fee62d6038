"""The adapter's own node, sans-IO: CSR core, ROM, topology map, claims, FCP, iso.

Layouts are written out here from IEEE 1394 / IEEE 1212 (and the INCOMING and
ISO_PACKET records from docs/host-adapter.md), not taken from the module.
"""

from __future__ import annotations

import struct
from fractions import Fraction

import pytest
from hypothesis import example, given
from hypothesis import strategies as st

from fw1394.packets.enums import ExtendedTCode, RCode, TCode
from fw1394.transport.host_adapter.iso import IsoChannels
from fw1394.transport.host_adapter.local_node import Incoming, LocalNode, cycle_timer

CSR = 0xFFFF_F000_0000
FCP_COMMAND = CSR + 0xB00
FCP_RESPONSE = CSR + 0xD00


def crc16_1212(data: bytes) -> int:
    """IEEE 1212 CRC-16 (x^16 + x^12 + x^5 + 1, initial 0), one bit at a time."""
    crc = 0
    for byte in data:
        crc ^= byte << 8
        for _ in range(8):
            crc = (crc << 1 ^ 0x1021 if crc & 0x8000 else crc << 1) & 0xFFFF
    return crc


def quadlets(data: bytes) -> list[int]:
    return [int.from_bytes(data[i : i + 4], "big") for i in range(0, len(data), 4)]


def read(node: LocalNode, offset: int, length: int = 4) -> tuple[int, bytes]:
    tcode = TCode.read_quadlet_request if length == 4 else TCode.read_block_request
    answer, pushes = node.request(Incoming(tcode, 0xFFC0, node.node_id, offset, length), "path")
    assert answer is not None and pushes == []
    return answer.rcode, answer.data


def write(node: LocalNode, offset: int, data: bytes) -> int:
    tcode = TCode.write_quadlet_request if len(data) == 4 else TCode.write_block_request
    incoming = Incoming(tcode, 0xFFC0, node.node_id, offset, len(data), data)
    answer, _ = node.request(incoming, "path")
    assert answer is not None
    return answer.rcode


def self_id(phy: int) -> bytes:
    # Self-ID packet #0: identifier 0b10, phy_ID in bits 29..24, link active (bit 22).
    return (0x80000000 | phy << 24 | 1 << 22).to_bytes(4, "big") + bytes(4)


def test_config_rom_is_an_ieee1212_bus_info_block_and_root_directory() -> None:
    node = LocalNode()
    rcode, rom = read(node, CSR + 0x400, 64)
    assert rcode == RCode.resp_complete
    q = quadlets(rom)
    info_length, crc_length, crc = q[0] >> 24, q[0] >> 16 & 0xFF, q[0] & 0xFFFF
    assert info_length == 4 and q[1] == int.from_bytes(b"1394", "big")
    assert crc == crc16_1212(rom[4 : 4 + 4 * crc_length])
    root_length, root_crc = q[5] >> 16, q[5] & 0xFFFF
    assert root_crc == crc16_1212(rom[24 : 24 + 4 * root_length])
    # The quadlet reads see the same bytes as the block read.
    assert [read(node, CSR + 0x400 + 4 * i)[1] for i in range(4)] == [
        rom[4 * i : 4 * i + 4] for i in range(4)
    ]


def test_topology_map_lists_the_self_ids_of_the_generation() -> None:
    node = LocalNode()
    node.bus_reset(2, 7, [self_id(0), self_id(1), self_id(2)])
    _, header = read(node, CSR + 0x1000, 12)
    length, generation, counts = quadlets(header)
    assert generation == 7 and counts == 3 << 16 | 3
    _, whole = read(node, CSR + 0x1000, 4 * (1 + (length >> 16)))
    assert length & 0xFFFF == crc16_1212(whole[4:])
    assert [q >> 24 & 0x3F for q in quadlets(whole[12:])] == [0, 1, 2]
    # NODE_IDS: bus 0x3FF, this node's physical ID.
    assert read(node, CSR + 0x008)[1] == (0xFFC2 << 16).to_bytes(4, "big")


@example(1.15)  # 1.15 * 8000 * 3072 in floats rounds up into the next tick
@given(st.floats(min_value=0, max_value=10_000, allow_nan=False))
def test_cycle_timer_fields(elapsed: float) -> None:
    value = cycle_timer(elapsed)
    ticks = int(Fraction(elapsed) * 24_576_000)  # the tick the exact time falls in
    assert value >> 25 == (ticks // 24_576_000) % 128
    assert value >> 12 & 0x1FFF == (ticks // 3072) % 8000
    assert value & 0xFFF == ticks % 3072


def test_state_clear_and_set() -> None:
    node = LocalNode()
    assert write(node, CSR + 0x004, (0x00000300).to_bytes(4, "big")) == RCode.resp_complete
    assert write(node, CSR + 0x000, (0x00000100).to_bytes(4, "big")) == RCode.resp_complete
    assert read(node, CSR + 0x000)[1] == (0x200).to_bytes(4, "big")
    assert write(node, CSR + 0x008, bytes(4)) == RCode.resp_type_error  # NODE_IDS: read-only
    assert read(node, 0x1234)[0] == RCode.resp_address_error


def test_channels_available_takes_compare_swap_and_resets_with_the_bus() -> None:
    node = LocalNode()

    def lock(expected: int, new: int) -> bytes:
        data = expected.to_bytes(4, "big") + new.to_bytes(4, "big")
        incoming = Incoming(
            TCode.lock_request,
            0xFFC0,
            node.node_id,
            CSR + 0x224,
            8,
            data,
            ExtendedTCode.compare_swap,
        )
        answer, _ = node.request(incoming, "path")
        assert answer is not None and answer.rcode == RCode.resp_complete
        return answer.data

    assert lock(0xFFFFFFFF, 0x7FFFFFFF) == b"\xff\xff\xff\xff"
    assert lock(0xFFFFFFFF, 0) == b"\x7f\xff\xff\xff"  # lost the race: unchanged
    assert read(node, CSR + 0x224)[1] == b"\x7f\xff\xff\xff"
    node.bus_reset(1, 2, [self_id(0), self_id(1)])
    assert read(node, CSR + 0x224)[1] == b"\xff\xff\xff\xff"


def test_fcp_writes_reach_every_listener_and_are_answered_at_once() -> None:
    node = LocalNode()
    node.listen("a", 11, FCP_COMMAND, 0x400, shared=True)
    node.listen("b", 12, FCP_COMMAND, 0x400, shared=True)
    frame = bytes.fromhex("0123456789abcdef")
    incoming = Incoming(TCode.write_block_request, 0xFFC1, 0xFFC2, FCP_RESPONSE, 8, frame, tlabel=5)
    answer, pushes = node.request(incoming, "path")
    assert answer is not None and answer.rcode == RCode.resp_complete
    assert {(p.owner, p.number) for p in pushes} == {("a", 11), ("b", 12)}
    # INCOMING: handle, tcode, tlabel, extended tcode, source, destination, offset,
    # length, then the data (docs/host-adapter.md section 8).
    fields = struct.unpack(">IBBHHHQI", pushes[0].data[:24])
    assert fields == (0, 1, 5, 0, 0xFFC1, 0xFFC2, FCP_RESPONSE, 8)
    assert pushes[0].data[24:] == frame


def test_a_claimed_range_is_answered_by_its_owner() -> None:
    node = LocalNode()
    node.listen("owner", 3, 0x1_0000_0000, 0x100, shared=False)
    with pytest.raises(ValueError, match="overlaps"):
        node.listen("other", 4, 0x1_0000_0080, 0x100, shared=False)
    with pytest.raises(ValueError, match="CSR core"):
        node.listen("other", 4, CSR + 0x400, 4, shared=False)
    incoming = Incoming(TCode.read_quadlet_request, 0xFFC0, 0xFFC1, 0x1_0000_0010, 4)
    answer, pushes = node.request(incoming, "the way back")
    assert answer is None and len(pushes) == 1 and pushes[0].owner == "owner"
    handle = struct.unpack(">I", pushes[0].data[:4])[0]
    with pytest.raises(ValueError):
        node.respond("intruder", handle, RCode.resp_complete, b"\0\0\0\1")
    path, reply = node.respond("owner", handle, RCode.resp_complete, b"\0\0\0\1")
    assert path == "the way back" and reply.data == b"\0\0\0\1"
    with pytest.raises(ValueError):  # answered once
        node.respond("owner", handle, RCode.resp_complete, b"")
    # The owner leaves with a request unanswered: it fails with an address error.
    node.request(incoming, "second")
    assert [(p, a.rcode) for p, a in node.forget("owner")] == [("second", RCode.resp_address_error)]
    answer, _ = node.request(incoming, "third")
    assert answer is not None and answer.rcode == RCode.resp_address_error


def test_rom_update_needs_the_current_version() -> None:
    node = LocalNode()
    rom = b"".join(q.to_bytes(4, "big") for q in node.rom)
    assert not node.update_rom(rom, 0)  # the same contents: no reset needed
    with pytest.raises(ValueError, match="changed"):
        node.update_rom(rom, 0)
    assert node.update_rom(rom[:-4], 1)
    assert node.rom_image()[0] == 2 and node.rom_image()[1:] == rom[:-4]


def test_iso_packets_reach_the_listeners_of_their_channel() -> None:
    channels = IsoChannels()
    channels.listen("five", 1, 1 << 5)
    channels.listen("many", 2, (1 << 5) | (1 << 9))
    pushes = channels.send(9, 1, 3, b"abcd", 7999)
    assert [(p.owner, p.number) for p in pushes] == [("many", 2)]
    assert pushes[0].data == bytes([9, 1, 3, 0]) + (7999).to_bytes(2, "big") + b"abcd"
    channels.listen("many", 2, 0)
    assert [p.owner for p in channels.send(5, 0, 0, b"", 0)] == ["five"]


def test_a_descriptor_joins_the_root_directory_and_leaves_with_its_owner() -> None:
    node = LocalNode()
    before = list(node.rom)
    # A unit directory: header (2 entries, CRC), specifier ID and version immediates.
    unit = [0x58595A, 0x616263]
    body = [0x12 << 24 | unit[0], 0x13 << 24 | unit[1]]
    block = [2 << 16 | crc16_1212(b"".join(q.to_bytes(4, "big") for q in body)), *body]
    data = b"".join(q.to_bytes(4, "big") for q in block)
    token = node.add_descriptor("program", 0x0C000000 | 0x0083C0, 0xD1000000, data)
    rom = node.rom
    root = 5  # after the bus-info block
    length = rom[root] >> 16
    root_bytes = b"".join(q.to_bytes(4, "big") for q in rom[root + 1 : root + 1 + length])
    assert rom[root] & 0xFFFF == crc16_1212(root_bytes)
    pointer = next(i for i in range(root + 1, root + 1 + length) if rom[i] >> 24 == 0xD1)
    assert rom[pointer - 1] == 0x0C0083C0  # the immediate entry just before it
    target = pointer + (rom[pointer] & 0xFFFFFF)
    assert rom[target : target + 3] == block
    # The text leaf the root directory named before is still where its entry points.
    leaf_entry = next(i for i in range(root + 1, root + 1 + length) if rom[i] >> 24 == 0x81)
    leaf = leaf_entry + (rom[leaf_entry] & 0xFFFFFF)
    assert b"fw1394" in b"".join(q.to_bytes(4, "big") for q in rom[leaf + 3 : leaf + 6])
    with pytest.raises(ValueError):
        node.remove_descriptor("someone else", token)
    with pytest.raises(ValueError, match="add up"):
        node.add_descriptor("program", 0, 0xD1000000, (5 << 16).to_bytes(4, "big"))
    node.forget("program")
    assert node.rom == before and node.descriptors == {}
