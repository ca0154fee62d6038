"""Wire layouts of every asynchronous packet: the single source of truth.

Each :class:`Layout` lists the header quadlets as bit fields (see
:mod:`fw1394.packets.fields`) and says whether a data block follows. From it
derive the ``construct`` structs that parse and build packets with and without
CRC quadlets, the field tables printed by the CLI and the dissectors, and the
fast decoder. No other module writes down where a field sits.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from construct import (
    Bytes,
    Compiled,
    Construct,
    GreedyBytes,
    IfThenElse,
    Int32ub,
    Padding,
    Struct,
    len_,
    this,
)

from fw1394.packets.enums import TCode
from fw1394.packets.fields import FieldSpec, Quadlets

Quadlet = Sequence[FieldSpec]

#: Quadlet 0 of every packet addressed to a node.
ROUTING: Quadlet = (
    ("destination_id", 16),
    ("tlabel", 6),
    ("retry", 2),
    ("tcode", 4),
    ("priority", 4),
)
#: Quadlets 1-2 of requests: who asks, and the 48-bit destination offset.
REQUEST_ADDRESS: tuple[Quadlet, ...] = (
    (("source_id", 16), ("offset", 16, 32)),
    (("offset", 32),),
)
#: Quadlets 1-2 of responses; the reserved bits are kept so any packet rebuilds exactly.
RESPONSE_STATUS: tuple[Quadlet, ...] = (
    (("source_id", 16), ("rcode", 4), ("reserved", 12, 32)),
    (("reserved", 32),),
)
QUADLET_DATA: Quadlet = (("quadlet_data", 32),)
BLOCK_LENGTH: Quadlet = (("data_length", 16), ("extended_tcode", 16))
#: Quadlet 0 of asynchronous stream packets (tcode 0xA).
STREAM: Quadlet = (
    ("data_length", 16),
    ("tag", 2),
    ("channel", 6),
    ("tcode", 4),
    ("sy", 4),
)
HEADER_CRC: Quadlet = (("header_crc", 32),)


#: The data block of block packets: data, then zero padding to a quadlet boundary.
#: Parsing trusts data_length; building writes the data as given, so a packet whose
#: data_length disagrees with its data can still be built (the fuzzer needs them).
#: Written with ``this`` expressions only, so construct can compile it.
DATA_BLOCK = (
    "data" / IfThenElse(this._parsing, Bytes(this.header["data_length"]), GreedyBytes),
    Padding(-len_(this.data) % 4),
)


@dataclass(frozen=True)
class Layout:
    """How one kind of asynchronous packet is laid out on the wire."""

    name: str
    tcode: TCode
    quadlets: tuple[Quadlet, ...]
    has_data: bool
    #: Header fields the packet object does not store (implied by the kind).
    implied: tuple[str, ...] = ("tcode",)
    header: Quadlets = field(init=False, repr=False, compare=False)
    sealed_header: Quadlets = field(init=False, repr=False, compare=False)
    wire: Construct = field(init=False, repr=False, compare=False)
    bare: Construct = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        header = Quadlets(*self.quadlets)
        sealed = Quadlets(*self.quadlets, HEADER_CRC)
        if self.has_data:
            wire: Construct = Struct("header" / sealed, *DATA_BLOCK, "data_crc" / Int32ub)
            bare: Construct = Struct("header" / header, *DATA_BLOCK)
        else:
            wire, bare = sealed, header
        object.__setattr__(self, "header", header)
        object.__setattr__(self, "sealed_header", sealed)
        object.__setattr__(self, "wire", wire)
        object.__setattr__(self, "bare", bare)

    def parser(self, *, crc: bool) -> Compiled:
        """The compiled construct of the whole packet (compiled on first use)."""
        key = (self.tcode, crc)
        compiled = _COMPILED.get(key)
        if compiled is None:
            compiled = _COMPILED[key] = (self.wire if crc else self.bare).compile()
        return compiled

    @property
    def header_size(self) -> int:
        """Bytes of header before the header CRC."""
        return 4 * len(self.quadlets)

    @property
    def fields(self) -> tuple[str, ...]:
        """Header field names a packet object of this kind carries."""
        return tuple(n for n in self.header.names if n not in self.implied)

    def describe(self) -> list[dict[str, Any]]:
        """Field table: quadlet, bit range and width of every bit field."""
        return [
            {"field": f.name, "quadlet": f.quadlet, "msb": f.msb, "lsb": f.lsb, "shift": f.shift}
            for f in self.sealed_header.bitfields
        ]


_COMPILED: dict[tuple[TCode, bool], Compiled] = {}


def _request(*tail: Quadlet) -> tuple[Quadlet, ...]:
    return (ROUTING, *REQUEST_ADDRESS, *tail)


def _response(*tail: Quadlet) -> tuple[Quadlet, ...]:
    return (ROUTING, *RESPONSE_STATUS, *tail)


LAYOUTS: dict[TCode, Layout] = {
    layout.tcode: layout
    for layout in (
        Layout("write_quadlet_request", TCode.write_quadlet_request, _request(QUADLET_DATA), False),
        Layout("write_block_request", TCode.write_block_request, _request(BLOCK_LENGTH), True),
        Layout("write_response", TCode.write_response, _response(), False),
        Layout("read_quadlet_request", TCode.read_quadlet_request, _request(), False),
        Layout("read_block_request", TCode.read_block_request, _request(BLOCK_LENGTH), False),
        Layout(
            "read_quadlet_response", TCode.read_quadlet_response, _response(QUADLET_DATA), False
        ),
        Layout("read_block_response", TCode.read_block_response, _response(BLOCK_LENGTH), True),
        Layout("cycle_start", TCode.cycle_start, _request(QUADLET_DATA), False),
        Layout("lock_request", TCode.lock_request, _request(BLOCK_LENGTH), True),
        Layout("stream_data", TCode.stream_data, (STREAM,), True),
        Layout("lock_response", TCode.lock_response, _response(BLOCK_LENGTH), True),
    )
}

#: Where the tcode sits: the same four bits of quadlet 0 in every layout (byte, shift).
_TCODE = next(f for f in Quadlets(ROUTING).bitfields if f.name == "tcode")
TCODE_BYTE, TCODE_SHIFT = (31 - _TCODE.lsb) // 8, _TCODE.lsb % 8
