"""The fast case generator: wire bytes from a seeded :class:`random.Random`.

Hypothesis draws are thorough but cost about a millisecond each; a fuzzing
campaign needs tens of thousands of cases a second. This generator makes the
same kinds of packets as :mod:`fw1394.fuzz.strategies` (valid packets of every
kind, the malformations of :mod:`fw1394.fuzz.malform`, mutations of a seed
corpus) with plain ``random``, so a seed fixes the whole sequence. Each case
comes with a label naming how it was made, for the coverage report.
"""

from __future__ import annotations

import random
from bisect import bisect
from collections.abc import Callable, Sequence
from itertools import accumulate
from typing import Any, TypeVar

from fw1394.fuzz import malform
from fw1394.fuzz.mutate import havoc
from fw1394.fuzz.offsets import (
    BOUNDARY_OFFSETS,
    CSR_BASE,
    GENERIC_INDICES,
    OFFSET_MASK,
    OffsetModel,
    aliased,
)
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    CycleStart,
    ExtendedTCode,
    LockRequest,
    LockResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    StreamPacket,
    WriteResponse,
)
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS, MAX_NODES, bus_of, phy_of
from fw1394.packets.nodeid import node_id as node_id_of

T = TypeVar("T")
#: The 1394a S400 limit on a block; longer ones are a classic parser trap.
MAX_BLOCK = 2048
#: CSR space and the configuration ROM, where 1394 addresses bytes.
CSR_SPAN = 0x800

#: Packet kinds and how often they are made: mostly requests, since those are
#: what a node serves, but every kind the wire can carry turns up.
KIND_WEIGHTS: tuple[tuple[type[AsyncPacket], int], ...] = (
    (QuadletReadRequest, 20),
    (BlockReadRequest, 14),
    (QuadletWriteRequest, 20),
    (BlockWriteRequest, 16),
    (LockRequest, 6),
    (WriteResponse, 2),
    (QuadletReadResponse, 2),
    (BlockReadResponse, 2),
    (LockResponse, 1),
    (CycleStart, 2),
    (StreamPacket, 2),
)
#: Malformations of a fresh packet, by label, and how often.
MALFORMATION_WEIGHTS: tuple[tuple[str, int], ...] = (
    ("valid", 45),
    ("bad-header-crc", 10),
    ("bad-data-crc", 6),
    ("no-crc", 3),
    ("truncated", 6),
    ("over-long", 5),
    ("length-mismatch", 8),
    ("length-mismatch+crc", 6),
    ("unknown-tcode", 4),
)


class Generator:
    """Cases for a node at ``node_id`` whose offsets ``model`` describes.

    ``corpus`` holds seed packets (wire bytes) that are mutated for
    ``corpus_share`` of the cases; ``mutate_share`` of the cases mutate a
    recently generated packet instead of making a new one.
    """

    def __init__(
        self,
        node_id: int,
        model: OffsetModel,
        rng: random.Random,
        corpus: Sequence[bytes] = (),
        *,
        corpus_share: float = 0.3,
        mutate_share: float = 0.2,
        source_id: int = node_id_of(MAX_NODES - 1),
    ) -> None:
        self.node_id = node_id
        self.model = model
        self.rng = rng
        self.corpus = list(corpus)
        self.corpus_share = corpus_share if self.corpus else 0.0
        self.mutate_share = mutate_share
        self.source_id = source_id
        self._recent: list[bytes] = []
        self._kinds = [k for k, _ in KIND_WEIGHTS]
        self._kind_weights = list(accumulate(w for _, w in KIND_WEIGHTS))
        self._malformations = [m for m, _ in MALFORMATION_WEIGHTS]
        self._malformation_weights = list(accumulate(w for _, w in MALFORMATION_WEIGHTS))
        self._builders: dict[type[AsyncPacket], Callable[[], dict[str, Any]]] = {
            QuadletReadRequest: self._quadlet_read,
            BlockReadRequest: self._block_read,
            QuadletWriteRequest: self._quadlet_write,
            BlockWriteRequest: self._block_write,
            LockRequest: self._lock,
            WriteResponse: self._response,
            QuadletReadResponse: self._quadlet_response,
            BlockReadResponse: self._block_response,
            LockResponse: self._lock_response,
            CycleStart: self._cycle_start,
            StreamPacket: self._stream,
        }

    # -- cases --------------------------------------------------------------------------
    def case(self) -> tuple[bytes, str]:
        """The next case: wire bytes and a label saying how they were made."""
        rng = self.rng
        draw = rng.random()
        if draw < self.corpus_share:
            raw, fixed = havoc(rng, rng.choice(self.corpus))
            return raw, "corpus-mutation+crc" if fixed else "corpus-mutation"
        if draw < self.corpus_share + self.mutate_share and self._recent:
            raw, fixed = havoc(rng, rng.choice(self._recent))
            return raw, "mutation+crc" if fixed else "mutation"
        raw = self.valid()
        recent = self._recent
        if len(recent) < 256:
            recent.append(raw)
        else:
            recent[rng.randrange(256)] = raw
        label = _pick(rng, self._malformations, self._malformation_weights)
        return self.malformed(raw, label)

    def valid(self) -> bytes:
        """A sound packet of a random kind (correct CRCs)."""
        cls = _pick(self.rng, self._kinds, self._kind_weights)
        return encode_packet(cls(**self._builders[cls]()))

    def malformed(self, raw: bytes, label: str) -> tuple[bytes, str]:
        """``raw`` broken as ``label`` says (a label that does not apply keeps it valid)."""
        rng = self.rng
        if label == "bad-header-crc":
            return malform.flip_header_crc(raw, 1 << rng.randrange(32)), label
        if label == "bad-data-crc" and len(raw) > (malform.header_size(raw) or len(raw)):
            return malform.flip_data_crc(raw, rng.getrandbits(32) | 1), label
        if label == "no-crc":
            return malform.without_crcs(raw), label
        if label == "truncated":
            return malform.truncated(raw, rng.randrange(1, len(raw))), label
        if label == "over-long":
            extra = rng.randbytes(rng.choice((1, 2, 4, 4, 8, 64)))
            return malform.over_long(raw, extra), label
        if label.startswith("length-mismatch") and len(raw) > (malform.header_size(raw) or 0):
            changed = malform.with_data_length(
                raw, self._declared_length(), fix_crc=label.endswith("crc")
            )
            return changed, label
        if label == "unknown-tcode":
            return malform.with_tcode(raw, rng.choice(malform.UNKNOWN_TCODES)), label
        return raw, "long-block" if _long_block(raw) else "valid"

    # -- fields -------------------------------------------------------------------------
    def destination(self) -> int:
        """Mostly the target; else any of the other 62 node IDs alike, broadcast, other
        buses and random IDs (a node that answers for node 5 is as wrong as one
        that answers for node 1)."""
        rng = self.rng
        node, bus = phy_of(self.node_id), bus_of(self.node_id)
        draw = rng.random()
        if draw < 0.66:
            return self.node_id
        if draw < 0.80:
            other = rng.randrange(BROADCAST_PHY - 1)
            return node_id_of(other + (other >= node), bus)
        if draw < 0.86:
            return node_id_of(BROADCAST_PHY, bus)
        if draw < 0.91:
            buses = [b for b in (0, 1, LOCAL_BUS - 1, LOCAL_BUS) if b != bus]
            return node_id_of(node, rng.choice(buses))
        if draw < 0.94:
            return node_id_of(BROADCAST_PHY, rng.randrange(LOCAL_BUS))
        return rng.getrandbits(16)

    def offset(self) -> int:
        """Where the target decodes something, in its own addressing: its registers and
        their neighbours, any quadlet index (a board addressed by index) or any byte
        offset, misaligned ones included (CSR space), and the boundaries."""
        rng, model = self.rng, self.model
        draw = rng.random()
        if draw < 0.50:
            return rng.choice(model.registers)
        if draw < 0.60:
            return self._neighbour(rng.choice(model.registers))
        if draw < 0.68:
            return aliased(rng.choice(model.registers), rng.getrandbits(32) | 1)
        if draw < 0.78:
            return rng.choice(BOUNDARY_OFFSETS)
        if draw < 0.94:
            return self._addressed()
        return rng.getrandbits(48) & OFFSET_MASK

    def _neighbour(self, register: int) -> int:
        """A register's neighbour: the next indices, or bytes around it (misaligned too)."""
        rng = self.rng
        step = rng.choice((-3, -2, -1, 1, 2, 3))
        if not self.model.quadlet_index:
            step *= rng.choice((1, 4))
        return (register + step) & OFFSET_MASK

    def _addressed(self) -> int:
        rng = self.rng
        if self.model.quadlet_index:
            # Every index of the first spaces' registers, then anywhere in the 16 bits.
            return rng.randrange(GENERIC_INDICES) if rng.random() < 0.6 else rng.getrandbits(16)
        if rng.random() < 0.4:
            return CSR_BASE + rng.randrange(CSR_SPAN)  # byte addressed: misaligned too
        offset = rng.getrandbits(16)
        return offset & ~3 if rng.random() < 0.6 else offset

    def quadlet(self) -> int:
        rng = self.rng
        if rng.random() < 0.3:
            return rng.choice((0, 1, 0x8000_0000, 0xFFFF_FFFF, 0x7FFF_FFFF, 0x0000_FFFF))
        return rng.getrandbits(32)

    def _length(self) -> int:
        """A block length: mostly short, sometimes up to the 2048-byte limit or past it."""
        rng = self.rng
        draw = rng.random()
        if draw < 0.62:
            return 4 * rng.randint(1, 32)
        if draw < 0.76:
            return rng.choice((0, 1, 2, 3, 5, 6, 7))
        if draw < 0.86:
            return 4 * rng.randint(33, 128)
        if draw < 0.92:
            return 4 * rng.randint(129, MAX_BLOCK // 4)
        if draw < 0.96:
            return rng.choice((MAX_BLOCK + 4, MAX_BLOCK + 1, 2 * MAX_BLOCK))
        return rng.randrange(MAX_BLOCK)

    def _declared_length(self) -> int:
        """A data_length to write over the real one (any 16-bit value can be claimed)."""
        rng = self.rng
        return (
            rng.choice((0, 0xFFFF, 0xFFFC, MAX_BLOCK + 4)) if rng.random() < 0.3 else self._length()
        )

    def _data(self) -> bytes:
        length = self._length()
        # A long block of random bytes costs time for nothing: zeros serve as well.
        return bytes(length) if length > 256 else self.rng.randbytes(length)

    def _routing(self) -> dict[str, Any]:
        rng = self.rng
        return {
            "destination_id": self.destination(),
            "tlabel": rng.getrandbits(6),
            "retry": rng.getrandbits(2) if rng.random() < 0.2 else 0,
            "priority": rng.getrandbits(4) if rng.random() < 0.1 else 0,
            "source_id": self.source_id if rng.random() < 0.85 else rng.getrandbits(16),
        }

    def _request(self) -> dict[str, Any]:
        return {**self._routing(), "offset": self.offset()}

    def _quadlet_read(self) -> dict[str, Any]:
        return self._request()

    def _block_read(self) -> dict[str, Any]:
        extended = 0 if self.rng.random() < 0.9 else self.rng.getrandbits(16)
        return {**self._request(), "data_length": self._length(), "extended_tcode": extended}

    def _quadlet_write(self) -> dict[str, Any]:
        return {**self._request(), "quadlet_data": self.quadlet()}

    def _block_write(self) -> dict[str, Any]:
        extended = 0 if self.rng.random() < 0.9 else self.rng.getrandbits(16)
        return {**self._request(), "data": self._data(), "extended_tcode": extended}

    def _lock(self) -> dict[str, Any]:
        rng = self.rng
        extended = rng.choice([*(int(e) for e in ExtendedTCode), 0, 8, 0xFFFF])
        data = rng.randbytes(rng.choice((4, 8, 8, 16, 16, 3, 12, 32)))
        return {**self._request(), "extended_tcode": extended, "data": data}

    def _response(self) -> dict[str, Any]:
        return {**self._routing(), "rcode": self.rng.getrandbits(4)}

    def _quadlet_response(self) -> dict[str, Any]:
        return {**self._response(), "quadlet_data": self.quadlet()}

    def _block_response(self) -> dict[str, Any]:
        return {**self._response(), "data": self._data()}

    def _lock_response(self) -> dict[str, Any]:
        return {**self._response(), "data": self.rng.randbytes(4), "extended_tcode": 2}

    def _cycle_start(self) -> dict[str, Any]:
        return {**self._routing(), "quadlet_data": self.quadlet()}

    def _stream(self) -> dict[str, Any]:
        rng = self.rng
        return {"channel": rng.getrandbits(6), "tag": rng.getrandbits(2), "data": self._data()}


def _pick(rng: random.Random, items: list[T], cumulative: list[int]) -> T:
    """One of ``items`` by weight (``cumulative``: running totals of the weights).

    What ``random.choices`` does, without building a list per call.
    """
    return items[bisect(cumulative, rng.random() * cumulative[-1])]


def _long_block(raw: bytes) -> bool:
    size = malform.header_size(raw)
    return size is not None and len(raw) > size + MAX_BLOCK + 4
