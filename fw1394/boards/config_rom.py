"""A minimal IEEE 1212 / 1394 configuration ROM for every emulated node, and its GUID.

A 1394 host finds out who a node is by reading its configuration ROM at CSR
offset 0xFFFF_F000_0400 (Linux's firewire-core does it after every bus reset,
and keys devices by the GUID in it). A board whose firmware has a ROM of its
own (the QLA board, :mod:`fw1394.boards.qla1.config_rom`) serves that one;
every other node gets this one, in the general format:

=========  ==================================================================
0x400      ``info_length`` 4, ``crc_length`` 4, CRC-16 of the next 4 quadlets
0x404      bus name "1394" (0x31333934)
0x408      bus options: cyc_clk_acc unspecified (0xFF), max_rec 10 (2048-byte
           payloads), max_ROM 2 (block reads), link speed S400
0x40C      GUID high: node vendor ID (24 bits), chip ID bits 39..32
0x410      GUID low: chip ID bits 31..0
0x414      root directory: {length, CRC-16}; Vendor (immediate), a textual
           descriptor leaf "fw1394", Node_Capabilities, Model (immediate:
           24 bits of the hash of the board kind), a textual descriptor leaf
           naming the board kind
=========  ==================================================================

The GUID is an EUI-64 that names one node of one bus, the same every time
that node starts: vendor ID :data:`VENDOR_ID` (its locally-administered bit
set: no company's block), then a 40-bit chip ID of 24 bits of the BLAKE2b
hash of the bus name, the node's rank (its order key, which the bus
supervisor gives every node and keeps across restarts; 0xFF if none) and its
board ID. Two nodes of one bus differ as long as their (rank, board ID)
differ; the same node on another bus gets another GUID.

Reads of the ROM window past the ROM's end read 0 (the window is
zero-filled); writes into the window are refused with an address error (a
ROM is read-only). The rest of the CSR space and every other offset reach
the board as before.
"""

from __future__ import annotations

import hashlib
from dataclasses import dataclass

from fw1394.crc import crc16_1212
from fw1394.engine.space import AddressError, AddressSpace

#: CSR offset of the configuration ROM and the end of its window.
ROM_ADDRESS = 0xFFFF_F000_0400
ROM_WINDOW_END = 0xFFFF_F000_0800
BUS_NAME_1394 = 0x31333934
#: cyc_clk_acc 0xFF (not specified), max_rec 0xA, max_ROM 2, generation 0, S400.
BUS_OPTIONS = 0x00FF_A202
#: The node vendor ID of emulated nodes: the EUI-64 locally-administered bit
#: (0x02 in the first octet) set, so it can be no real company's.
VENDOR_ID = 0x02F139
#: Split timeout, 64-bit fixed addressing, lost/cycle-master capable bits: a
#: transaction-capable node with no isochronous resources of its own.
NODE_CAPABILITIES = 0x0083C0
VENDOR_NAME = b"fw1394"
NO_RANK = 0xFF
_QUADLET = 4

# IEEE 1212 key bytes: key type (2 bits) and key ID (6 bits).
_VENDOR = 0x03
_NODE_CAPABILITIES = 0x0C
_MODEL = 0x17
_TEXT_LEAF = 0x81


def node_guid(bus: str, board_id: int, rank: int | None) -> int:
    """The GUID of the node with ``board_id`` and ``rank`` on bus ``bus``."""
    digest = hashlib.blake2b(bus.encode(), digest_size=3).digest()
    chip_id = (
        int.from_bytes(digest, "big") << 16
        | (NO_RANK if rank is None else rank & 0xFF) << 8
        | board_id & 0xFF
    )
    return VENDOR_ID << 40 | chip_id


def _block(body: list[int]) -> list[int]:
    """{length, CRC-16 of the body}, then the body."""
    data = b"".join(q.to_bytes(_QUADLET, "big") for q in body)
    return [len(body) << 16 | crc16_1212(data), *body]


def _text_leaf(text: bytes) -> list[int]:
    """A textual descriptor leaf: type 0, specifier 0, minimal ASCII, the text padded."""
    padded = text + bytes(-len(text) % _QUADLET)
    words = [int.from_bytes(padded[i : i + _QUADLET], "big") for i in range(0, len(padded), 4)]
    return _block([0, 0, *words])


def model_id(model: str) -> int:
    """The 24-bit Model ID of board kind ``model`` (stable, distinct in practice)."""
    return int.from_bytes(hashlib.blake2b(model.encode(), digest_size=3).digest(), "big")


def build_rom(guid: int, model: str) -> list[int]:
    """The ROM's quadlets from offset 0x400 on, for board kind ``model``."""
    body = [BUS_NAME_1394, BUS_OPTIONS, guid >> 32, guid & 0xFFFF_FFFF]
    data = b"".join(q.to_bytes(_QUADLET, "big") for q in body)
    bus_info = [4 << 24 | 4 << 16 | crc16_1212(data), *body]
    vendor_leaf = _text_leaf(VENDOR_NAME)
    model_leaf = _text_leaf(model.encode()[:64])
    # A leaf entry's value is the distance from the entry itself, in quadlets.
    entries = 5
    root = _block(
        [
            _VENDOR << 24 | VENDOR_ID,
            _TEXT_LEAF << 24 | entries - 1,  # vendor leaf, right after the directory
            _NODE_CAPABILITIES << 24 | NODE_CAPABILITIES,
            _MODEL << 24 | model_id(model),
            _TEXT_LEAF << 24 | 1 + len(vendor_leaf),  # model leaf, after the vendor leaf
        ]
    )
    return bus_info + root + vendor_leaf + model_leaf


@dataclass
class RomWindow:
    """``board`` with the ROM ``rom`` served at 0xFFFF_F000_0400..07FF."""

    board: AddressSpace
    rom: list[int]

    def __post_init__(self) -> None:
        image = b"".join(q.to_bytes(_QUADLET, "big") for q in self.rom)
        self._image = image.ljust(ROM_WINDOW_END - ROM_ADDRESS, b"\0")

    def __getattr__(self, name: str) -> object:
        # Anything else a board offers (tools, tests) is the board's own.
        if name == "board":
            raise AttributeError(name)
        return getattr(self.board, name)

    def _slice(self, offset: int, length: int) -> bytes | None:
        """The ROM bytes at ``offset``, None if the access is not in the window at all."""
        if not ROM_ADDRESS <= offset < ROM_WINDOW_END:
            return None
        start = offset - ROM_ADDRESS
        if start % _QUADLET or length % _QUADLET or offset + length > ROM_WINDOW_END:
            raise AddressError(f"{length} bytes at {offset:#x}: ROM reads are whole quadlets")
        return self._image[start : start + length]

    def read_quadlet(self, offset: int) -> int:
        data = self._slice(offset, _QUADLET)
        if data is None:
            return self.board.read_quadlet(offset)
        return int.from_bytes(data, "big")

    def read_block(self, offset: int, length: int) -> bytes:
        data = self._slice(offset, length)
        return self.board.read_block(offset, length) if data is None else data

    def write_quadlet(self, offset: int, value: int) -> None:
        self._refuse_rom(offset)
        self.board.write_quadlet(offset, value)

    def write_block(self, offset: int, data: bytes) -> None:
        self._refuse_rom(offset)
        self.board.write_block(offset, data)

    def set_time(self, ticks: int) -> None:
        self.board.set_time(ticks)

    @staticmethod
    def _refuse_rom(offset: int) -> None:
        if ROM_ADDRESS <= offset < ROM_WINDOW_END:
            raise AddressError(f"{offset:#x} is in the configuration ROM (read-only)")


def with_config_rom(
    board: AddressSpace, *, bus: str, board_id: int, rank: int | None, model: str
) -> RomWindow:
    """``board`` (of kind ``model``) behind the ROM of the node it is on bus ``bus``."""
    return RomWindow(board, build_rom(node_guid(bus, board_id, rank), model))
