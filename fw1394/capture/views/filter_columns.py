"""The columns a display filter reads: packets of a batch, or transactions, by field name.

Every column is int64 with -1 where the row has no such field; a field with
two values per row (a transaction's request and response tcode) has two
columns. Columns are built on first use, so a filter on ``tcode`` touches
nothing else.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np

from fw1394.capture.analysis.columns import Decoded, Problem, ack_codes
from fw1394.capture.analysis.transactions import Transactions
from fw1394.capture.formats import pseudo_header as ph
from fw1394.capture.formats.batch import Batch, quadlets_at
from fw1394.capture.formats.record import RecordType
from fw1394.capture.views.display_filter import FIELDS
from fw1394.packets import LAYOUTS

Builder = Callable[[], tuple[np.ndarray, ...]]


class _Lazy(Mapping[str, tuple[np.ndarray, ...]]):
    def __init__(self, builders: dict[str, Builder]) -> None:
        self._builders = builders
        self._cache: dict[str, tuple[np.ndarray, ...]] = {}

    def __getitem__(self, name: str) -> tuple[np.ndarray, ...]:
        if name not in self._cache:
            built = self._builders[name]()
            if FIELDS[name].text is None:
                built = tuple(np.asarray(c, np.int64) for c in built)
            self._cache[name] = built
        return self._cache[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._builders)

    def __len__(self) -> int:
        return len(self._builders)


#: Filter names whose packet column is the decoder's header field of another name.
_HEADER_FIELDS = {"src": "source_id", "dst": "destination_id"}
_PACKET_HEADER_FIELDS: tuple[str, ...] = ("src", "dst", "tlabel", "retry", "priority", "offset")
_PACKET_HEADER_FIELDS += ("rcode", "data_length", "extended_tcode", "quadlet_data", "channel")
_PACKET_HEADER_FIELDS += ("tag", "sy", "reserved")


#: Per tcode: header quadlets (without the CRC), whether a data block follows, the name.
_TABLE = 16
_HEADER_COUNT = np.full(_TABLE, -1, np.int64)
_HAS_DATA = np.zeros(_TABLE, bool)
_KIND_NAMES: list[str | None] = [None] * _TABLE
for _tcode, _layout in LAYOUTS.items():
    _HEADER_COUNT[int(_tcode)] = _layout.header.count
    _HAS_DATA[int(_tcode)] = _layout.has_data
    _KIND_NAMES[int(_tcode)] = _layout.name


@dataclass
class Links:
    """What pairing the whole trace tells each frame (as Wireshark's second pass does):
    by frame number, -1 where the frame has no such field."""

    request_in: np.ndarray
    response_in: np.ndarray
    latency: np.ndarray
    attempts: np.ndarray

    @classmethod
    def of(cls, transactions: Iterable[Transactions], frames: int) -> Links:
        size = frames + 1
        links = cls(*(np.full(size, -1, np.int64) for _ in range(4)))
        for tx in transactions:
            if not len(tx):
                continue
            first, last, answer = tx["first_frame"], tx["frame"], tx["resp_frame"]
            asked = (first >= 0) & (first != answer)  # unsolicited: the response alone
            answered = asked & (answer >= 0)
            for frame in (first, last):
                links.response_in[frame[answered]] = answer[answered]
                links.attempts[frame[asked]] = tx["attempts"][asked]
            links.request_in[answer[answered]] = first[answered]
            links.attempts[answer[answered]] = tx["attempts"][answered]
            latency = tx["latency_ns"]
            timed = answered & (latency >= 0)
            links.latency[answer[timed]] = latency[timed]
        return links

    def at(self, column: np.ndarray, frames: np.ndarray) -> np.ndarray:
        inside = (frames >= 0) & (frames < len(column))
        return np.where(inside, column[np.clip(frames, 0, len(column) - 1)], -1)


def _crc_columns(batch: Batch, decoded: Decoded) -> dict[str, Builder]:
    """Header and data CRC quadlets, and their status as Wireshark numbers it
    (0 bad, 1 good, 2 not computed); valid is 1 or 0 where computed."""
    tcode = np.where(decoded.tcode >= 0, decoded.tcode, 0)
    is_async = decoded.tcode >= 0
    count = np.where(is_async, _HEADER_COUNT[tcode], -1)
    crc = (batch.flags & ph.flag_bit("crc_present")) != 0
    placeholder = (batch.flags & ph.flag_bit("crc_placeholder")) != 0
    header_at = batch.start + 4 * count
    has_header_crc = is_async & (count > 0) & crc & (batch.length >= 4 * (count + 1))
    padded = (decoded.fields["data_length"] + 3) & ~3
    data_at = decoded.data_start + padded
    has_data_crc = (
        is_async & _HAS_DATA[tcode] & crc & (decoded.data_start >= 0)
        & (decoded.data_present >= padded + 4) & (padded >= 0)
    )  # fmt: skip
    phy = (batch.record_type == RecordType.phy_packet) & crc & (batch.length >= 8)

    def stored(where: np.ndarray, at: np.ndarray) -> np.ndarray:
        values = np.full(len(batch), -1, np.int64)
        rows = np.flatnonzero(where)
        if len(rows):
            values[rows] = quadlets_at(batch.buf, at[rows]).astype(np.int64)
        return values

    def status(where: np.ndarray, problem: Problem, computed: np.ndarray) -> np.ndarray:
        bad = (decoded.problems & problem) != 0
        value = np.where(computed, np.where(bad, 0, 1), 2)
        return np.where(where, value, -1)

    def valid(where: np.ndarray, problem: Problem, computed: np.ndarray) -> np.ndarray:
        good = (decoded.problems & problem) == 0
        return np.where(where & computed, good.astype(np.int64), -1)

    computed = ~placeholder
    return {
        "header_crc": lambda: (stored(has_header_crc, header_at),),
        "header_crc.status": lambda: (status(has_header_crc, Problem.header_crc, computed),),
        "header_crc.valid": lambda: (valid(has_header_crc, Problem.header_crc, computed),),
        "data_crc": lambda: (stored(has_data_crc, data_at),),
        "data_crc.status": lambda: (status(has_data_crc, Problem.data_crc, computed),),
        "data_crc.valid": lambda: (valid(has_data_crc, Problem.data_crc, computed),),
        "phy.check": lambda: (stored(phy, batch.start + 4),),
        "phy.check.status": lambda: (status(phy, Problem.phy_check, np.ones(len(batch), bool)),),
        "phy.check.valid": lambda: (valid(phy, Problem.phy_check, np.ones(len(batch), bool)),),
    }


def _text_columns(batch: Batch, decoded: Decoded) -> dict[str, Builder]:
    def kind() -> tuple[Any, ...]:
        tcode = decoded.tcode
        whole = batch.length >= 4 * np.where(tcode >= 0, _HEADER_COUNT[np.maximum(tcode, 0)], 0)
        names = [
            _KIND_NAMES[t] if t >= 0 and ok else None
            for t, ok in zip(tcode.tolist(), whole.tolist(), strict=True)
        ]
        return (np.array(names, dtype=object),)

    def data() -> tuple[Any, ...]:
        padded = (decoded.fields["data_length"] + 3) & ~3
        present = np.minimum(padded, decoded.data_present)
        buf = batch.buf
        blocks = [
            bytes(buf[start : start + size]) if start >= 0 and size > 0 else None
            for start, size in zip(decoded.data_start.tolist(), present.tolist(), strict=True)
        ]
        return (np.array(blocks, dtype=object),)

    return {"kind": kind, "data": data}


def _pseudo_header_columns(batch: Batch) -> dict[str, Builder]:
    def flag(name: str) -> Builder:
        field = ph.FIELDS[f"flags.{name}"]
        return lambda: ((batch.flags >> field.lsb) & field.mask,)

    def constant(value: int) -> Builder:
        return lambda: (np.full(len(batch), value, np.int64),)

    def byte(column: np.ndarray) -> Builder:
        return lambda: (np.where(column >= 0, column, ph.NO_NODE),)

    builders = {
        name: flag(name.removeprefix("ph.flags."))
        for name in FIELDS
        if name.startswith("ph.flags.")
    }
    present = (batch.flags & ph.flag_bit("ack_present")) != 0
    builders |= {
        "ph.version": constant(ph.VERSION),
        "ph.header_length": constant(ph.HEADER_LENGTH),
        "ph.reserved": constant(0),
        "ph.observer": byte(batch.observer),
        "ph.ack": lambda: (np.where(present & (batch.ack >= 0), batch.ack, 0),),
    }
    return builders


def packet_columns(
    batch: Batch, decoded: Decoded, origin_ns: int, links: Links | None = None
) -> _Lazy:
    """Filter columns of every record of ``batch``; ``links`` gives the fields that
    pairing the whole trace decides (request_in, response_in, latency, attempts)."""

    def header(name: str) -> Builder:
        return lambda: (decoded.fields[_HEADER_FIELDS.get(name, name)],)

    def time() -> tuple[np.ndarray, ...]:
        unknown = batch.flag("time_unknown") != 0
        return (np.where(unknown, -1, batch.ts_ns - origin_ns),)

    builders: dict[str, Builder] = {name: header(name) for name in _PACKET_HEADER_FIELDS}
    builders |= {
        "tcode": lambda: (decoded.tcode,),
        "ack": lambda: (np.where(batch.ack >= 0, batch.ack, ack_codes(batch)),),
        "generation": lambda: (batch.generation,),
        "speed": lambda: (batch.speed,),
        "record_type": lambda: (batch.record_type,),
        "sender": lambda: (batch.sender,),
        "frame": lambda: (batch.frame,),
        "time": time,
    }

    def ack_parity() -> tuple[np.ndarray, ...]:
        rows = (batch.record_type == RecordType.ack) & (batch.length >= 1)
        byte = batch.buf[np.where(rows, batch.start, 0)].astype(np.int64)
        return (np.where(rows, byte & 0xF, -1),)

    builders["ack_parity"] = ack_parity
    builders |= _crc_columns(batch, decoded)
    builders |= _text_columns(batch, decoded)
    builders |= _pseudo_header_columns(batch)
    if links is not None:

        def linked(column: np.ndarray) -> Builder:
            return lambda: (links.at(column, batch.frame),)

        builders["request_in"] = linked(links.request_in)
        builders["response_in"] = linked(links.response_in)
        builders["latency"] = linked(links.latency)
        builders["attempts"] = linked(links.attempts)
    assert set(builders) <= set(FIELDS)
    return _Lazy(builders)


def transaction_columns(tx: Transactions, origin_ns: int) -> _Lazy:
    """Filter columns of transactions: the request's fields, with the response's beside them."""

    def both(request: str, response: str) -> Builder:
        return lambda: (tx[request], tx[response])

    def one(name: str) -> Builder:
        return lambda: (tx[name],)

    def time() -> tuple[np.ndarray, ...]:
        return (np.where(tx["time_known"] != 0, tx["first_ts"] - origin_ns, -1),)

    builders: dict[str, Builder] = {
        "tcode": both("tcode", "resp_tcode"),
        "src": one("requester"),
        "dst": one("responder"),
        "tlabel": one("tlabel"),
        "offset": one("offset"),
        "rcode": one("rcode"),
        "data_length": both("data_length", "resp_data_length"),
        "quadlet_data": both("quadlet_data", "resp_quadlet"),
        "ack": both("ack", "resp_ack"),
        "generation": one("generation"),
        "frame": both("first_frame", "resp_frame"),
        "time": time,
        "latency": one("latency_ns"),
        "attempts": one("attempts"),
        "request_in": one("first_frame"),
        "response_in": one("resp_frame"),
    }
    assert set(builders) <= set(FIELDS)
    return _Lazy(builders)
