"""The adapter's own node: what a PC's 1394 link and its kernel answer for it.

A PC on a 1394 bus is a node other nodes can address: its kernel answers the
CSR core registers (STATE_CLEAR, NODE_IDS, CYCLE_TIME, the isochronous
resource manager's registers, the configuration ROM, the topology map),
passes writes to the FCP registers to every program listening for them, and
hands requests to address ranges a program claimed to that program, whose
answer goes back as the response. :class:`LocalNode` is that behaviour for
the host adapter, sans-IO: requests in (from the bus, or from a client of the
adapter addressing the adapter's own node), answers and notifications out.
Who the clients are and how answers travel is the adapter's business; here a
client is any hashable owner and an answer's way back is an opaque ``path``.

Claimed ranges are exclusive; FCP listening is shared. A request into a
claimed range is *deferred*: the owner gets it as an :data:`INCOMING` record
with a handle, and :meth:`LocalNode.respond` with that handle ends it.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Hashable, Sequence
from dataclasses import dataclass, field
from fractions import Fraction

import crcmod
from construct import GreedyBytes, Int8ub, Int16ub, Int32ub, Int64ub, Struct

from fw1394.packets import nodeid
from fw1394.packets.enums import ExtendedTCode, RCode, TCode
from fw1394.packets.nodeid import BROADCAST_PHY

#: Offset of the CSR core registers in every node's address space.
CSR_BASE = 0xFFFF_F000_0000
STATE_CLEAR = 0x000
STATE_SET = 0x004
NODE_IDS = 0x008
RESET_START = 0x00C
SPLIT_TIMEOUT_HI = 0x018
SPLIT_TIMEOUT_LO = 0x01C
CYCLE_TIME = 0x200
BUS_TIME = 0x204
BUS_MANAGER_ID = 0x21C
BANDWIDTH_AVAILABLE = 0x220
CHANNELS_AVAILABLE_HI = 0x224
CHANNELS_AVAILABLE_LO = 0x228
CONFIG_ROM = 0x400
CONFIG_ROM_END = 0x800
FCP_COMMAND = 0xB00
FCP_RESPONSE = 0xD00
FCP_END = 0xF00
TOPOLOGY_MAP = 0x1000
TOPOLOGY_MAP_END = 0x1400

#: IEEE 1394 cycle timer: 8000 cycles a second, 3072 ticks of 24.576 MHz a cycle.
CYCLES_PER_SECOND = 8000
TICKS_PER_CYCLE = 3072
#: Bandwidth units of a bus with nothing allocated (IEEE 1394a 8.3.2.3.7).
BANDWIDTH_UNITS = 4915

#: What the owner of a claimed range gets for each request into it (``data`` of a
#: push reply): the handle to answer with, the request's header fields, and its data
#: (write data; for a lock, the argument then the data).
INCOMING = Struct(
    "handle" / Int32ub,
    "tcode" / Int8ub,
    "tlabel" / Int8ub,
    "extended_tcode" / Int16ub,
    "source" / Int16ub,  # node ID of the requester
    "destination" / Int16ub,  # node ID the request was addressed to
    "offset" / Int64ub,
    "length" / Int32ub,  # bytes asked for (read), or carried (write, lock)
    "data" / GreedyBytes,
)
#: A bus-state push (``data`` of a watch reply): nodes on the bus and the
#: physical ID of the isochronous resource manager; generation and the adapter's own
#: physical ID are in the reply's header.
BUS_STATE = Struct("nodes" / Int8ub, "irm" / Int8ub)
#: A configuration ROM as the ``config_rom`` op carries it: its version, its bytes.
ROM_IMAGE = Struct("version" / Int8ub, "rom" / GreedyBytes)

_crc16 = crcmod.mkCrcFun(0x11021, initCrc=0, rev=False, xorOut=0)
_READS = (TCode.read_quadlet_request, TCode.read_block_request)
_WRITES = (TCode.write_quadlet_request, TCode.write_block_request)
_RCODES = frozenset(int(r) for r in RCode)

#: BUS_MANAGER_ID while no node is bus manager: 63, the broadcast physical ID.
NO_BUS_MANAGER = BROADCAST_PHY


@dataclass(frozen=True, slots=True)
class Incoming:
    """A request addressed to the adapter's node, whoever sent it."""

    tcode: int
    source: int
    destination: int
    offset: int
    length: int = 4
    data: bytes = b""
    extended_tcode: int = 0
    tlabel: int = 0

    def pack(self, handle: int) -> bytes:
        record: bytes = INCOMING.build(
            {
                "handle": handle,
                "tcode": self.tcode,
                "tlabel": self.tlabel,
                "extended_tcode": self.extended_tcode,
                "source": self.source,
                "destination": self.destination,
                "offset": self.offset,
                "length": self.length,
                "data": self.data,
            }
        )
        return record


@dataclass(frozen=True, slots=True)
class Answer:
    """How a request to the adapter's node ends: an rcode and the response data."""

    rcode: int
    data: bytes = b""


@dataclass(frozen=True, slots=True)
class Push:
    """A record for one client: ``data`` as the reply to its request ``number``."""

    owner: Hashable
    number: int
    data: bytes


@dataclass(frozen=True, slots=True)
class Listener:
    owner: Hashable
    number: int
    start: int
    end: int
    #: Shared listeners (FCP) are told of writes the node answers itself.
    shared: bool


@dataclass
class Deferred:
    owner: Hashable
    path: object
    request: Incoming


@dataclass(frozen=True, slots=True)
class Descriptor:
    """Blocks a program added to the ROM, and the root directory entries naming them."""

    owner: Hashable
    #: An immediate entry put before the pointer (0: none).
    immediate: int
    #: The pointer entry's key byte (bits 31-24; the offset is filled in).
    key: int
    #: The blocks, each with its own header (length, CRC), as the program gave them.
    blocks: tuple[int, ...]


def adapter_config_rom(
    vendor: int = 0x001394, chip: int = 1, descriptors: Sequence[Descriptor] = ()
) -> list[int]:
    """The adapter's configuration ROM: bus-info block, root directory, a text leaf,
    and the blocks of ``descriptors`` (each named by an entry of the root directory)."""

    def block(body: list[int], length: int | None = None) -> list[int]:
        data = b"".join(q.to_bytes(4, "big") for q in body)
        return [(len(body) if length is None else length) << 16 | _crc16(data), *body]

    # irmc, cmc, isc; cycle clock accuracy 100 ppm; max_rec 2048 bytes; S400.
    bus_options = 0xE0000000 | 0x64 << 16 | 0xA << 12 | 2
    bus_info = block([0x31333934, bus_options, vendor << 8, chip], length=0x0404)
    leaf = block([0, 0, *_quadlets(b"fw1394 host adapter")])
    # Entries point forward by quadlets from themselves (IEEE 1212 7.7.18): lay out the
    # root directory first, then the blocks in entry order.
    entries: list[tuple[int, list[int] | None]] = [
        (0x0C << 24 | 0x0083C0, None),
        (0x03 << 24 | vendor, None),
        (0x81 << 24, leaf),
    ]
    for descriptor in descriptors:
        if descriptor.immediate:
            entries.append((descriptor.immediate, None))
        entries.append((descriptor.key & 0xFF000000, list(descriptor.blocks)))
    root_start = len(bus_info) + 1  # the first entry, after the root directory's header
    next_block = root_start + len(entries)
    body, blocks = [], []
    for index, (entry, target) in enumerate(entries):
        if target is not None:
            entry |= next_block - (root_start + index)
            blocks += target
            next_block += len(target)
        body.append(entry)
    return bus_info + block(body) + blocks


def _quadlets(text: bytes) -> list[int]:
    padded = text + bytes(-len(text) % 4)
    return [int.from_bytes(padded[i : i + 4], "big") for i in range(0, len(padded), 4)]


def cycle_timer(elapsed: float) -> int:
    """The CYCLE_TIME register ``elapsed`` seconds after the cycle master started."""
    # Exact: a float product rounds up across a tick boundary for some times (1.15 s).
    ticks = int(Fraction(elapsed) * CYCLES_PER_SECOND * TICKS_PER_CYCLE)
    cycles, offset = divmod(ticks, TICKS_PER_CYCLE)
    seconds, cycle = divmod(cycles, CYCLES_PER_SECOND)
    return (seconds & 0x7F) << 25 | cycle << 12 | offset


@dataclass
class LocalNode:
    """The adapter's node: its CSR core, configuration ROM, claimed ranges."""

    clock: Callable[[], float] = time.monotonic
    rom: list[int] = field(default_factory=adapter_config_rom)
    rom_version: int = 0
    phy_id: int = BROADCAST_PHY  # no physical ID of its own until the first reset
    generation: int = 0
    self_ids: tuple[bytes, ...] = ()
    state: int = 0
    split_timeout: tuple[int, int] = (0, 800 << 19)
    bus_manager_id: int = NO_BUS_MANAGER
    bandwidth: int = BANDWIDTH_UNITS
    channels: tuple[int, int] = (0xFFFFFFFF, 0xFFFFFFFF)
    listeners: list[Listener] = field(default_factory=list)
    descriptors: dict[int, Descriptor] = field(default_factory=dict)
    deferred: dict[int, Deferred] = field(default_factory=dict)
    _handles: int = 0
    _epoch: float = field(default_factory=time.monotonic)

    def __post_init__(self) -> None:
        self._epoch = self.clock()

    @property
    def node_id(self) -> int:
        return nodeid.node_id(self.phy_id)

    def cycle_time(self) -> int:
        """The node's CYCLE_TIME register now (the adapter is the bus's cycle master)."""
        return cycle_timer(self.clock() - self._epoch)

    # -- the bus ------------------------------------------------------------------------
    def bus_reset(self, phy_id: int, generation: int, self_ids: Sequence[bytes]) -> None:
        """A new generation: the node's own physical ID and the self-ID packets."""
        self.phy_id, self.generation, self.self_ids = phy_id, generation, tuple(self_ids)
        # The resource manager's registers start over at every reset (IEEE 1394a 8.3.2.3).
        self.bus_manager_id, self.bandwidth = NO_BUS_MANAGER, BANDWIDTH_UNITS
        self.channels = (0xFFFFFFFF, 0xFFFFFFFF)

    def bus_state(self) -> bytes:
        """The :data:`BUS_STATE` record of this generation."""
        nodes = len(self.self_ids)
        # The root (highest physical ID) is resource manager: this chain's root is
        # the adapter, whose isc bit is set.
        state: bytes = BUS_STATE.build({"nodes": nodes, "irm": max(nodes - 1, 0)})
        return state

    # -- claims -------------------------------------------------------------------------
    def listen(self, owner: Hashable, number: int, start: int, length: int, shared: bool) -> None:
        """Give ``owner`` the requests to ``[start, start + length)`` (its request ``number``)."""
        end = start + length
        if length <= 0 or start < 0 or end > 1 << 48:
            raise ValueError(f"no address range of {length} bytes at 0x{start:012x}")
        if shared:
            if not (start >= CSR_BASE + FCP_COMMAND and end <= CSR_BASE + FCP_END):
                raise ValueError("only the FCP registers can be listened to by many")
        else:
            if start < CSR_BASE + TOPOLOGY_MAP_END and end > CSR_BASE:
                raise ValueError(f"0x{start:012x} is in the node's own CSR core")
            for other in self.listeners:
                if not other.shared and start < other.end and other.start < end:
                    raise ValueError(
                        f"0x{start:012x}-0x{end:012x} overlaps a range another program claimed"
                    )
        self.listeners.append(Listener(owner, number, start, end, shared))

    def unlisten(self, owner: Hashable, start: int) -> None:
        kept = [x for x in self.listeners if not (x.owner == owner and x.start == start)]
        if len(kept) == len(self.listeners):
            raise ValueError(f"no range at 0x{start:012x} was claimed")
        self.listeners = kept

    def forget(self, owner: Hashable) -> list[tuple[object, Answer]]:
        """``owner`` left: its claims go; requests it owed an answer fail."""
        self.listeners = [x for x in self.listeners if x.owner != owner]
        for token in [t for t, d in self.descriptors.items() if d.owner == owner]:
            self.remove_descriptor(owner, token)  # the kernel reverts them when a client leaves
        gone = [h for h, d in self.deferred.items() if d.owner == owner]
        return [(self.deferred.pop(h).path, Answer(RCode.resp_address_error)) for h in gone]

    def respond(
        self, owner: Hashable, handle: int, rcode: int, data: bytes
    ) -> tuple[object, Answer]:
        """``owner``'s answer to the request it got as ``handle``: where it goes, and what."""
        waiting = self.deferred.get(handle)
        if waiting is None or waiting.owner != owner:
            raise ValueError(f"no request {handle} waits for this program's answer")
        del self.deferred[handle]
        if rcode not in _RCODES:
            raise ValueError(f"rcode {rcode} is not a response code")
        return waiting.path, Answer(rcode, data if rcode == RCode.resp_complete else b"")

    # -- requests -----------------------------------------------------------------------
    def request(self, incoming: Incoming, path: object) -> tuple[Answer | None, list[Push]]:
        """Serve ``incoming``: its answer (None: deferred to an owner), and the pushes."""
        offset, end = incoming.offset, incoming.offset + incoming.length
        if offset >= CSR_BASE + FCP_COMMAND and end <= CSR_BASE + FCP_END:
            return self._fcp(incoming)
        for claim in self.listeners:
            if not claim.shared and claim.start <= offset and end <= claim.end:
                self._handles = self._handles % 0xFFFFFFFF + 1
                handle = self._handles
                self.deferred[handle] = Deferred(claim.owner, path, incoming)
                return None, [Push(claim.owner, claim.number, incoming.pack(handle))]
        if CSR_BASE <= offset < CSR_BASE + TOPOLOGY_MAP_END:
            return self._csr(incoming, offset - CSR_BASE), []
        return Answer(RCode.resp_address_error), []

    def _fcp(self, incoming: Incoming) -> tuple[Answer, list[Push]]:
        if incoming.tcode not in _WRITES:
            return Answer(RCode.resp_type_error), []
        pushes = [
            Push(x.owner, x.number, incoming.pack(0))
            for x in self.listeners
            if x.shared and x.start <= incoming.offset < x.end
        ]
        return Answer(RCode.resp_complete), pushes

    def _csr(self, incoming: Incoming, address: int) -> Answer:
        tcode, length = incoming.tcode, incoming.length
        if address % 4 or length % 4 or length == 0:
            return Answer(RCode.resp_type_error)
        if tcode in _READS:
            image = self._readable(address, length)
            if image is None:
                return Answer(RCode.resp_address_error)
            return Answer(RCode.resp_complete, image)
        if tcode in _WRITES and length == 4:
            return self._write(address, int.from_bytes(incoming.data[:4], "big"))
        if tcode == TCode.lock_request:
            return self._lock(address, incoming)
        return Answer(RCode.resp_type_error)

    def _readable(self, address: int, length: int) -> bytes | None:
        """The bytes at CSR ``address``; None where no register answers a read."""
        if address >= CONFIG_ROM and address + length <= CONFIG_ROM_END:
            return _image(self.rom, (address - CONFIG_ROM) // 4, length)
        if address >= TOPOLOGY_MAP and address + length <= TOPOLOGY_MAP_END:
            return _image(self.topology_map(), (address - TOPOLOGY_MAP) // 4, length)
        if length != 4:
            return None
        registers = {
            STATE_CLEAR: self.state,
            STATE_SET: self.state,
            NODE_IDS: self.node_id << 16,
            SPLIT_TIMEOUT_HI: self.split_timeout[0],
            SPLIT_TIMEOUT_LO: self.split_timeout[1],
            BUS_MANAGER_ID: self.bus_manager_id,
            BANDWIDTH_AVAILABLE: self.bandwidth,
            CHANNELS_AVAILABLE_HI: self.channels[0],
            CHANNELS_AVAILABLE_LO: self.channels[1],
        }
        if address == CYCLE_TIME:
            return self.cycle_time().to_bytes(4, "big")
        if address == BUS_TIME:
            return (int(self.clock() - self._epoch) & 0xFFFFFFFF).to_bytes(4, "big")
        value = registers.get(address)
        return None if value is None else value.to_bytes(4, "big")

    def _write(self, address: int, value: int) -> Answer:
        if address == STATE_CLEAR:
            self.state &= ~value & 0xFFFFFFFF
        elif address == STATE_SET:
            self.state |= value
        elif address == SPLIT_TIMEOUT_HI:
            self.split_timeout = (value & 7, self.split_timeout[1])
        elif address == SPLIT_TIMEOUT_LO:
            self.split_timeout = (self.split_timeout[0], value & 0xFFF80000)
        elif address == RESET_START:
            pass  # a command reset touches no state the adapter keeps
        else:
            return Answer(RCode.resp_type_error)
        return Answer(RCode.resp_complete)

    def _lock(self, address: int, incoming: Incoming) -> Answer:
        """compare_swap on the resource manager's registers (the only lock they take)."""
        names = (BUS_MANAGER_ID, BANDWIDTH_AVAILABLE, CHANNELS_AVAILABLE_HI, CHANNELS_AVAILABLE_LO)
        if address not in names or incoming.extended_tcode != ExtendedTCode.compare_swap:
            return Answer(RCode.resp_type_error)
        if len(incoming.data) != 8:
            return Answer(RCode.resp_type_error)
        expected = int.from_bytes(incoming.data[:4], "big")
        new = int.from_bytes(incoming.data[4:], "big")
        old = {
            BUS_MANAGER_ID: self.bus_manager_id,
            BANDWIDTH_AVAILABLE: self.bandwidth,
            CHANNELS_AVAILABLE_HI: self.channels[0],
            CHANNELS_AVAILABLE_LO: self.channels[1],
        }[address]
        if old == expected:
            if address == BUS_MANAGER_ID:
                self.bus_manager_id = new
            elif address == BANDWIDTH_AVAILABLE:
                self.bandwidth = new
            elif address == CHANNELS_AVAILABLE_HI:
                self.channels = (new, self.channels[1])
            else:
                self.channels = (self.channels[0], new)
        return Answer(RCode.resp_complete, old.to_bytes(4, "big"))

    def topology_map(self) -> list[int]:
        """The TOPOLOGY_MAP register file: header, generation, counts, self-ID packets."""
        quadlets = [int.from_bytes(raw[:4], "big") for raw in self.self_ids]
        body = [self.generation & 0xFFFFFFFF, len(self.self_ids) << 16 | len(quadlets), *quadlets]
        data = b"".join(q.to_bytes(4, "big") for q in body)
        return [len(body) << 16 | _crc16(data), *body]

    # -- the configuration ROM ------------------------------------------------------------
    def rom_image(self) -> bytes:
        image: bytes = ROM_IMAGE.build(
            {"version": self.rom_version, "rom": b"".join(q.to_bytes(4, "big") for q in self.rom)}
        )
        return image

    def add_descriptor(self, owner: Hashable, immediate: int, key: int, data: bytes) -> int:
        """Add ``data`` (whole blocks, headers included) to the ROM; its token."""
        if not data or len(data) % 4:
            raise ValueError(f"a descriptor of {len(data)} bytes is not whole quadlets")
        words = tuple(int.from_bytes(data[i : i + 4], "big") for i in range(0, len(data), 4))
        at = 0
        while at < len(words):  # the blocks must fill the data exactly, as the kernel checks
            at += (words[at] >> 16) + 1
        if at != len(words):
            raise ValueError("the descriptor's block lengths do not add up to its size")
        token = max(self.descriptors, default=0) + 1
        descriptors = {**self.descriptors, token: Descriptor(owner, immediate, key, words)}
        rom = adapter_config_rom(descriptors=list(descriptors.values()))
        if len(rom) * 4 > CONFIG_ROM_END - CONFIG_ROM:
            raise ValueError("the configuration ROM would not fit 1 KiB")
        self.descriptors, self.rom = descriptors, rom
        self.rom_version = (self.rom_version + 1) & 0xFF
        return token

    def remove_descriptor(self, owner: Hashable, token: int) -> None:
        """Take the blocks of ``token`` out of the ROM again."""
        descriptor = self.descriptors.get(token)
        if descriptor is None or descriptor.owner != owner:
            raise ValueError(f"no descriptor {token} of this program is in the ROM")
        del self.descriptors[token]
        self.rom = adapter_config_rom(descriptors=list(self.descriptors.values()))
        self.rom_version = (self.rom_version + 1) & 0xFF

    def update_rom(self, rom: bytes, version: int) -> bool:
        """Replace the ROM a program read as ``version``; whether its contents changed."""
        if version != self.rom_version:
            raise ValueError(
                f"the configuration ROM changed since version {version} (now {self.rom_version})"
            )
        if not rom or len(rom) % 4 or len(rom) > CONFIG_ROM_END - CONFIG_ROM:
            raise ValueError(f"a configuration ROM of {len(rom)} bytes is not 4-1024 quadlet bytes")
        new = [int.from_bytes(rom[i : i + 4], "big") for i in range(0, len(rom), 4)]
        changed = new != self.rom
        self.rom = new
        self.rom_version = (self.rom_version + 1) & 0xFF
        return changed


def _image(quadlets: list[int], index: int, length: int) -> bytes:
    words = quadlets[index : index + length // 4]
    words += [0] * (length // 4 - len(words))
    return b"".join(q.to_bytes(4, "big") for q in words)
