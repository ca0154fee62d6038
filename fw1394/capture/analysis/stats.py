"""Statistics over a whole trace, in memory that does not grow with its length.

Counts are fixed-size arrays; latencies go into logarithmic histograms (64
bins per octave, so a percentile is within 1.1 % of the exact value; the
maximum is exact) and a bounded random sample kept for the plots.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from fw1394.capture.analysis.columns import Decoded, Problem, ack_codes, problem_names
from fw1394.capture.analysis.transaction_model import ERROR_FLAGS, Flag, Kind
from fw1394.capture.analysis.transactions import Transactions
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.record import RecordType
from fw1394.packets import AckCode, RCode, TCode, name_of
from fw1394.packets.accessors import TCODE
from fw1394.packets.nodeid import PHY_ID_MASK

BINS_PER_OCTAVE = 64
OCTAVES = 44  # 1 ns .. about 4.9 hours
PERCENTILES = (50, 90, 99)
SAMPLE_SIZE = 200_000
_I64 = np.int64


def _bin_of(latency: np.ndarray) -> np.ndarray:
    index = np.floor(np.log2(np.maximum(latency, 1)) * BINS_PER_OCTAVE).astype(_I64)
    clipped: np.ndarray = np.clip(index, 0, BINS - 1)
    return clipped


BINS = BINS_PER_OCTAVE * OCTAVES + 1


class LatencyHistograms:
    """Latencies in nanoseconds for ``groups`` groups, binned logarithmically.

    Counts, sums, minimum and maximum are exact; percentiles come from the bins.
    """

    def __init__(self, groups: int) -> None:
        self.bins = np.zeros((groups, BINS), _I64)
        self.count = np.zeros(groups, _I64)
        self.total = np.zeros(groups, _I64)
        self.maximum = np.full(groups, -1, _I64)
        self.minimum = np.full(groups, np.iinfo(_I64).max, _I64)

    def add(self, group: np.ndarray, latency: np.ndarray) -> None:
        groups = len(self.count)
        flat = group * BINS + _bin_of(latency)
        self.bins += np.bincount(flat, minlength=groups * BINS).reshape(groups, BINS)
        self.count += np.bincount(group, minlength=groups)
        self.total += np.bincount(group, weights=latency, minlength=groups).astype(_I64)
        np.maximum.at(self.maximum, group, latency)
        np.minimum.at(self.minimum, group, latency)

    def groups(self) -> list[int]:
        return np.flatnonzero(self.count).tolist()

    def percentile(self, group: int, q: float) -> int | None:
        count = int(self.count[group])
        if not count:
            return None
        rank = max(int(np.ceil(q / 100 * count)), 1)
        index = int(np.searchsorted(np.cumsum(self.bins[group]), rank))
        # The geometric middle of the bin, kept within the exact extremes.
        value = 2 ** ((index + 0.5) / BINS_PER_OCTAVE)
        return int(min(max(value, self.minimum[group]), self.maximum[group]))

    def summary(self, group: int) -> dict[str, Any]:
        count = int(self.count[group])
        result: dict[str, Any] = {"count": count}
        for q in PERCENTILES:
            result[f"p{q}_ns"] = self.percentile(group, q)
        result["max_ns"] = int(self.maximum[group]) if count else None
        result["mean_ns"] = int(self.total[group]) // count if count else None
        return result


@dataclass
class Sample:
    """A uniform random sample of (latency, data length, request tcode), for plots."""

    capacity: int = SAMPLE_SIZE
    seen: int = 0
    latency: np.ndarray = field(default_factory=lambda: np.zeros(0, _I64))
    size: np.ndarray = field(default_factory=lambda: np.zeros(0, _I64))
    tcode: np.ndarray = field(default_factory=lambda: np.zeros(0, _I64))
    _random: np.random.Generator = field(default_factory=lambda: np.random.default_rng(1394))

    def add(self, latency: np.ndarray, size: np.ndarray, tcode: np.ndarray) -> None:
        fresh = len(latency)
        if not fresh:
            return
        # Reservoir sampling in bulk: item number i survives with probability capacity / i.
        numbers = self.seen + 1 + np.arange(fresh)
        self.seen += fresh
        room = max(self.capacity - len(self.latency), 0)
        keep_all = numbers <= self.capacity
        slots = np.where(keep_all, 0, self._random.integers(0, np.maximum(numbers, 1), dtype=_I64))
        chosen = keep_all | (slots < self.capacity)
        appended = np.flatnonzero(chosen & keep_all)[:room]
        self.latency = np.concatenate([self.latency, latency[appended]])
        self.size = np.concatenate([self.size, size[appended]])
        self.tcode = np.concatenate([self.tcode, tcode[appended]])
        replace = np.flatnonzero(chosen & ~keep_all)
        targets = slots[replace]
        self.latency[targets] = latency[replace]
        self.size[targets] = size[replace]
        self.tcode[targets] = tcode[replace]


class Stats:
    """Everything the stats view prints, accumulated batch by batch."""

    def __init__(self) -> None:
        self.records = np.zeros(len(RecordType), _I64)
        self.tcodes = np.zeros(16, _I64)
        self.acks = np.zeros(17, _I64)  # index 16: packet with no ack known
        self.rcodes = np.zeros(16, _I64)
        self.problems: dict[str, int] = {}
        self.kinds = np.zeros(len(Kind), _I64)
        self.flags: dict[str, int] = {}
        self.bus_resets = 0
        self.issues = 0  # unreadable records, set by whoever read the input
        self.first_ns: int | None = None
        self.last_ns: int | None = None
        self.latency = LatencyHistograms(1)
        self.by_kind = LatencyHistograms(16)  # by request tcode
        self.by_node = LatencyHistograms(64)  # by responder's node number
        self.sample = Sample()

    def add_batch(self, batch: Batch, decoded: Decoded, keep: np.ndarray | None = None) -> None:
        if keep is not None and not keep.all():
            batch, decoded = batch.select(keep), decoded.select(keep)
        kinds = batch.record_type
        self.records += np.bincount(kinds, minlength=len(RecordType))[: len(RecordType)]
        self.bus_resets += int((kinds == RecordType.bus_reset).sum())
        if len(batch):
            first, last = int(batch.ts_ns.min()), int(batch.ts_ns.max())
            self.first_ns = first if self.first_ns is None else min(self.first_ns, first)
            self.last_ns = last if self.last_ns is None else max(self.last_ns, last)
        packets = decoded.tcode >= 0
        self.tcodes += np.bincount(decoded.tcode[packets], minlength=16)[:16]
        # Each ack once: from the packet it was joined to, else from its own record.
        records = ack_codes(batch)
        joined = np.zeros(len(batch), bool)
        joined[1:] = (batch.record_type[:-1] == RecordType.async_packet) & (batch.ack[:-1] >= 0)
        unknown = packets & (batch.ack < 0) & ~np.append((records >= 0)[1:], False)
        acks = np.where(unknown, 16, batch.ack)
        acks = np.concatenate([acks[packets], records[(records >= 0) & ~joined]])
        self.acks += np.bincount(acks[acks >= 0], minlength=17)[:17]
        rcode = decoded.fields["rcode"]
        self.rcodes += np.bincount(rcode[rcode >= 0], minlength=16)[:16]
        seen = int(np.bitwise_or.reduce(decoded.problems)) if len(decoded.problems) else 0
        for flag in Problem:
            if not seen & flag:
                continue
            hits = int(((decoded.problems & flag) != 0).sum())
            if hits:
                name = problem_names(flag)[0]
                self.problems[name] = self.problems.get(name, 0) + hits

    def add_transactions(self, tx: Transactions, keep: np.ndarray | None = None) -> None:
        everything = keep is None or keep.all()

        def column(name: str) -> np.ndarray:
            values = tx[name]
            return values if everything else values[keep]

        if not len(tx):
            return
        self.kinds += np.bincount(column("kind"), minlength=len(Kind))[: len(Kind)]
        flags = column("flags")
        seen = int(np.bitwise_or.reduce(flags)) if len(flags) else 0
        for flag in Flag:
            if not seen & flag:
                continue
            hits = int(((flags & flag) != 0).sum())
            if hits and flag.name:
                self.flags[flag.name] = self.flags.get(flag.name, 0) + hits
        latency = column("latency_ns")
        timed = latency >= 0
        if not timed.any():
            return
        latency, tcode = latency[timed], column("tcode")[timed]
        self.latency.add(np.zeros(len(latency), _I64), latency)
        self.by_kind.add(tcode & TCODE.mask, latency)
        self.by_node.add(column("responder")[timed] & PHY_ID_MASK, latency)
        size = np.maximum(column("data_length")[timed], column("resp_data_length")[timed])
        self.sample.add(latency, np.where(size < 0, 4, size), tcode)

    @property
    def errors(self) -> int:
        transaction_errors = sum(
            count for name, count in self.flags.items() if Flag[name] & ERROR_FLAGS
        )
        return transaction_errors + sum(self.problems.values()) + self.issues

    def report(self) -> dict[str, Any]:
        duration = None
        if self.first_ns is not None and self.last_ns is not None:
            duration = (self.last_ns - self.first_ns) / 1e9
        return {
            "records": {kind.name: int(self.records[kind]) for kind in RecordType},
            "duration_s": duration,
            "bus_resets": self.bus_resets,
            "tcodes": _named(self.tcodes, TCode),
            "acks": {
                **_named(self.acks[:16], AckCode, zero_name="no_ack"),
                **({"unknown": int(self.acks[16])} if self.acks[16] else {}),
            },
            "rcodes": _named(self.rcodes, RCode),
            "transactions": {kind.name: int(self.kinds[kind]) for kind in Kind if self.kinds[kind]},
            "latency": self.latency.summary(0),
            "latency_by_kind": {
                name_of(TCode, code): self.by_kind.summary(code) for code in self.by_kind.groups()
            },
            "latency_by_node": {
                f"node {node}": self.by_node.summary(node) for node in self.by_node.groups()
            },
            "errors": {
                "total": self.errors,
                "unreadable_records": self.issues,
                **self.problems,
                **{name: n for name, n in self.flags.items() if Flag[name] & ERROR_FLAGS},
            },
            "notes": {name: n for name, n in self.flags.items() if not Flag[name] & ERROR_FLAGS},
        }


def _named(counts: np.ndarray, enum: Any, zero_name: str | None = None) -> dict[str, int]:
    result = {}
    for code, count in enumerate(counts.tolist()):
        if count:
            name = zero_name if code == 0 and zero_name else name_of(enum, code)
            result[name] = int(count)
    return result
