"""The Ethernet switch data at 0x40A0 as ``ethswitch`` reads it (jhu-eth1394.md §4.1).

``ethswitch`` reads the quadlet at 0x40A0, swaps it to host order and compares its
bytes in memory (little-endian) with "ESW0"; then it block-reads 32 quadlets from
0x40A0, swaps each and lays a little-endian C struct over them (port attributes in
the low half of quadlet 1, 16-bit packet counters from quadlet 2). That decoding
is written here.
"""

from __future__ import annotations

import struct

from fw1394.boards.qla1.board import Qla1Board


def host_view(data: bytes) -> bytes:
    """The block as ``ethswitch`` sees it in memory: each big-endian quadlet swapped
    to a little-endian host's order."""
    quadlets = struct.unpack(f">{len(data) // 4}I", data)
    return struct.pack(f"<{len(quadlets)}I", *quadlets)


def test_header_and_port_attributes_as_ethswitch_decodes_them() -> None:
    board = Qla1Board(board_id=0, firmware=9, fpga_version=3)
    header = board.read_quadlet(0x40A0).to_bytes(4, "little")
    assert header == b"ESW0"
    memory = host_view(board.read_block(0x40A0, 128))
    assert memory[:4] == b"ESW0"
    (attributes,) = struct.unpack_from("<H", memory, 4)
    active = [bool(attributes & 1 << port) for port in range(4)]
    fast = [bool(attributes & 0x10 << port) for port in range(4)]
    assert active == [True, False, False, True] and fast == active
    received = struct.unpack_from("<4H", memory, 8)
    assert received == (0, 0, 0, 0)


def test_no_switch_data_before_firmware_9_or_fpga_v3() -> None:
    for firmware, fpga in ((8, 3), (9, 2)):
        board = Qla1Board(board_id=0, firmware=firmware, fpga_version=fpga)
        assert board.read_quadlet(0x40A0) == 0
