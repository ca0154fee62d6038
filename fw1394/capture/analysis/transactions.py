"""Join requests, acks and responses into transactions, a batch at a time, with numpy.

A request and its response share (requester, responder, tlabel); they are
joined within one *epoch* (the stretch between two bus resets), because a
bus reset cancels every outstanding transaction. The matching itself is in
:mod:`fw1394.capture.analysis.pairing`; this module feeds it batch by batch:

* acks recorded as their own records are joined to the packet before them;
* requests still open at the end of a batch are carried into the next one,
  so memory stays bounded by the labels in flight, not by the trace size;
* an open request ends unanswered when its label is reused, a bus reset
  intervenes, it waits longer than the expiry, or the trace ends.

Results are :class:`Transactions` whose columns are gathered on first use:
statistics touch a dozen of them, the detailed views all.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

import numpy as np

from fw1394.capture.analysis import column_table as table
from fw1394.capture.analysis import pairing
from fw1394.capture.analysis.columns import CRC_PROBLEMS, Decoded, Problem, ack_codes
from fw1394.capture.analysis.transaction_model import (
    BROADCAST_NODE,
    COLUMNS,
    DEFAULT_EXPIRY_NS,
    EXPECTED,
    HALVED_LOCKS,
    I64,
    IS_ERROR_ACK,
    IS_REQUEST,
    IS_RESPONSE,
    IS_RETRY_ACK,
    IS_WRITE,
    MATCH_KEYS,
    NO_ACK,
    REQUEST_COLUMNS,
    RESPONSE_COLUMNS,
    Flag,
    Kind,
)
from fw1394.capture.formats import pseudo_header as ph
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.record import RecordType
from fw1394.packets import AckCode, ExtendedTCode, TCode

#: Request columns the matching needs for every request, not only the finished ones.
_CORE: tuple[str, ...] = ("ordinal", "epoch", "requester", "responder", "tlabel", "ack")
_CORE += ("tcode", "attempts", "busy", "problems", "ts", "time_known")


class _Place:
    """Where rows of a source live: in the carried table or in the batch (worked out once)."""

    __slots__ = ("carried", "fresh", "old")

    def __init__(self, source: _Source, index: np.ndarray) -> None:
        if source.carried:
            self.old: np.ndarray | None = index < source.carried
            self.carried = index[self.old]
            rest = index[~self.old] - source.carried
        else:
            self.old, self.carried, rest = None, index[:0], index
        self.fresh: np.ndarray = source.rows[rest] if len(source.rows) else rest


class _Source:
    """Columns of a batch's requests or responses, with carried rows in front."""

    def __init__(self, arrays: Mapping[str, np.ndarray], rows: np.ndarray, carry: table.Table):
        self._arrays = arrays
        self.rows = rows
        self._carry = carry
        self.carried = table.rows(carry)
        self.count = self.carried + len(rows)

    def get(self, name: str) -> np.ndarray:
        """The whole column, carried rows first."""
        if not len(self.rows):
            return self._carry.get(name, np.zeros(0, I64))
        fresh: np.ndarray = self._arrays[name][self.rows]
        return np.concatenate([self._carry[name], fresh]) if self.carried else fresh

    def place(self, index: np.ndarray) -> _Place:
        return _Place(self, index)

    def at(self, name: str, place: _Place) -> np.ndarray:
        """The column at the rows of ``place``."""
        if not len(self.rows):
            values: np.ndarray = self._carry.get(name, np.zeros(0, I64))
            carried: np.ndarray = values[place.carried]
            return carried
        fresh: np.ndarray = self._arrays[name][place.fresh]
        if place.old is None:
            return fresh
        out = np.empty(len(place.old), I64)
        out[place.old] = self._carry[name][place.carried]
        out[~place.old] = fresh
        return out


class Transactions:
    """Transactions that ended in one batch; ``tx["column"]`` gives a column."""

    def __init__(
        self,
        requests: _Source | None,
        responses: _Source,
        found: pairing.Sequence | None,
        chosen: np.ndarray,
        kind: np.ndarray,
        flags: np.ndarray,
    ) -> None:
        self._requests = requests
        self._responses = responses
        self._cache: dict[str, np.ndarray] = {}
        self._count = len(chosen)
        self._places: dict[str, _Place] = {}
        if found is not None:
            self._first, self._last = found.first[chosen], found.last[chosen]
            self._answer = found.answer[chosen]
            self._cache["attempts"] = found.attempts[chosen]
            self._cache["busy"] = found.busy[chosen]
            self._cache["problems"] = found.problems[chosen]
        else:  # unsolicited responses: ``chosen`` are response rows
            self._first = self._last = np.zeros(0, I64)
            self._answer = chosen
        self._cache["kind"] = kind
        self._cache["flags"] = flags
        self._finish()

    def __len__(self) -> int:
        return self._count

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = self._column(name)
        return self._cache[name]

    def as_table(self) -> table.Table:
        return {name: self[name] for name in COLUMNS}

    def _place(self, which: str) -> _Place:
        if which not in self._places:
            if which == "answer":
                source, index = self._responses, np.where(self._answer >= 0, self._answer, 0)
            else:
                assert self._requests is not None
                source, index = self._requests, self._first if which == "first" else self._last
            self._places[which] = source.place(index)
        return self._places[which]

    def _column(self, name: str) -> np.ndarray:
        if name in RESPONSE_COLUMNS:
            if not self._responses.count:
                return np.full(self._count, -1, I64)
            values = self._responses.at(name, self._place("answer"))
            return np.where(self._answer >= 0, values, -1)
        if self._requests is None:
            # Unsolicited: the keys come from the response, the rest is unknown.
            alias = {"first_ordinal": "resp_ordinal", "first_frame": "resp_frame"}
            alias |= {"first_ts": "resp_ts"} | {key: key for key in MATCH_KEYS}
            if name in alias:
                return self._responses.at(alias[name], self._place("answer"))
            return np.full(self._count, -1, I64)
        which = "first" if name.startswith("first_") else "last"
        return self._requests.at(name, self._place(which))

    def _finish(self) -> None:
        """Flags and kinds that depend on the response, and the latency."""
        flags, kind = self["flags"], self["kind"]
        has = self._answer >= 0
        rcode, resp_problems = self["rcode"], self["resp_problems"]
        flags[has & (rcode > 0)] |= Flag.rcode_error
        flags[has & ((resp_problems & CRC_PROBLEMS) != 0)] |= Flag.crc_error
        flags[has & ((resp_problems & ~CRC_PROBLEMS) != 0)] |= Flag.malformed
        if self._requests is None:
            self._cache["latency_ns"] = np.full(self._count, -1, I64)
            return
        tcode, resp_tcode = self["tcode"], self["resp_tcode"]
        flags[has & (resp_tcode != EXPECTED[np.clip(tcode, 0, 15)])] |= Flag.tcode_mismatch
        flags[has & self._length_mismatch()] |= Flag.length_mismatch
        concatenated = has & (self["ack"] == AckCode.ack_pending)
        concatenated &= self["resp_pkt_ordinal"] == self["pkt_ordinal"] + 1
        kind[concatenated] = Kind.concatenated
        timed = has & (self["time_known"] > 0) & (self["resp_time_known"] > 0)
        self._cache["latency_ns"] = np.where(timed, self["resp_ts"] - self["first_ts"], -1)

    def _length_mismatch(self) -> np.ndarray:
        tcode, resp_tcode = self["tcode"], self["resp_tcode"]
        requested, returned = self["data_length"], self["resp_data_length"]
        extended = self["extended_tcode"]
        read = (tcode == TCode.read_block_request) & (resp_tcode == TCode.read_block_response)
        lock = (tcode == TCode.lock_request) & (resp_tcode == TCode.lock_response)
        lock &= extended != ExtendedTCode.vendor_dependent
        lock_expected = np.where(np.isin(extended, HALVED_LOCKS), requested // 2, requested)
        mismatch: np.ndarray = (read & (returned != requested)) | (
            lock & (returned != lock_expected)
        )
        return mismatch


class Pairer:
    """Feed batches in order; each call returns the transactions that ended."""

    def __init__(self, expiry_ns: int = DEFAULT_EXPIRY_NS) -> None:
        self.expiry_ns = expiry_ns
        self._open: table.Table = table.empty(REQUEST_COLUMNS)
        self._ordinal = 0
        self._pkt_ordinal = 0
        self._epoch = 0
        self._last_unacked = -1  # ordinal of the batch's last record if an un-acked packet

    def feed(self, batch: Batch, decoded: Decoded) -> list[Transactions]:
        count = len(batch)
        kinds = batch.record_type
        ordinal = self._ordinal + np.arange(count, dtype=I64)
        epoch = self._epoch + np.cumsum(kinds == RecordType.bus_reset)
        not_ack = kinds != RecordType.ack
        pkt_ordinal = self._pkt_ordinal + np.cumsum(not_ack) - 1
        acks = self._joined_acks(batch)
        self._last_unacked = -1
        if count and kinds[-1] == RecordType.async_packet and acks[-1] < 0:
            self._last_unacked = int(ordinal[-1])
        self._ordinal += count
        self._pkt_ordinal += int(not_ack.sum())
        self._epoch = int(epoch[-1]) if count else self._epoch
        arrays, answers = _arrays(batch, decoded, acks, ordinal, pkt_ordinal, epoch)
        usable = (kinds == RecordType.async_packet) & ((decoded.problems & Problem.truncated) == 0)
        request_rows = np.flatnonzero(usable & IS_REQUEST[decoded.tcode])
        response_rows = np.flatnonzero(usable & IS_RESPONSE[decoded.tcode])
        requests = _Source(arrays, request_rows, self._open)
        responses = _Source(answers, response_rows, {})
        now = int(batch.ts_ns.max()) if count else 0
        return self._pair(requests, responses, now, final=False)

    def finish(self) -> list[Transactions]:
        """Close every request still open (the trace ended before their responses)."""
        requests = _Source({}, np.zeros(0, I64), self._open)
        responses = _Source({}, np.zeros(0, I64), table.empty((*RESPONSE_COLUMNS, *MATCH_KEYS)))
        return self._pair(requests, responses, 0, final=True)

    def _joined_acks(self, batch: Batch) -> np.ndarray:
        """Each packet's ack: from its pseudo-header, or from an ack record right after it."""
        acks = batch.ack.copy()
        ack_records = ack_codes(batch)
        follows = np.flatnonzero(ack_records[1:] >= 0) + 1
        target = follows - 1
        usable = (batch.record_type[target] == RecordType.async_packet) & (acks[target] < 0)
        acks[target[usable]] = ack_records[follows[usable]]
        if len(batch) and ack_records[0] >= 0 and self._last_unacked >= 0:
            chosen = self._open["ordinal"] == self._last_unacked
            self._open["ack"][chosen] = ack_records[0]
            self._open["busy"][chosen] += int(IS_RETRY_ACK[ack_records[0]])
        return acks

    def _pair(
        self, requests: _Source, responses: _Source, now: int, final: bool
    ) -> list[Transactions]:
        core = {name: requests.get(name) for name in _CORE}
        response_keys = {name: responses.get(name) for name in ("resp_ordinal", *MATCH_KEYS)}
        found = pairing.match(core, response_keys)
        pairing.match_broadcast(core, response_keys, found)
        kind, flags = self._resolve(core, found, now, final)
        done = np.flatnonzero(kind >= 0)
        done = done[np.argsort(found.last[done], kind="stable")]
        waiting = np.flatnonzero(kind < 0)
        waiting = waiting[np.argsort(found.last[waiting], kind="stable")]
        self._open = _carry(requests, found, waiting)
        results = [Transactions(requests, responses, found, done, kind[done], flags[done])]
        matched = np.zeros(responses.count, bool)
        matched[found.answer[found.answer >= 0]] = True
        if not matched.all():
            loose = np.flatnonzero(~matched)
            stray_kind = np.full(len(loose), Kind.unsolicited, I64)
            stray_flags = np.full(len(loose), int(Flag.unsolicited), I64)
            results.append(Transactions(None, responses, None, loose, stray_kind, stray_flags))
        return results

    def _resolve(
        self, core: Mapping[str, np.ndarray], found: pairing.Sequence, now: int, final: bool
    ) -> tuple[np.ndarray, np.ndarray]:
        """Kind of each transaction (-1: still waiting) and its flags."""
        last = found.last
        ack, tcode = core["ack"][last], core["tcode"][last]
        flags = np.zeros(len(last), I64)
        kind = np.full(len(last), -1, I64)
        answered = found.answer >= 0
        is_write = IS_WRITE[tcode]
        broadcast = (core["responder"][last] & BROADCAST_NODE) == BROADCAST_NODE
        flags[found.busy > 0] |= Flag.busy
        flags[(found.problems & CRC_PROBLEMS) != 0] |= Flag.crc_error
        flags[(found.problems & ~CRC_PROBLEMS) != 0] |= Flag.malformed
        errored = IS_ERROR_ACK[ack]
        missing = (ack == NO_ACK) & ~broadcast
        retrying = IS_RETRY_ACK[ack]
        kind[~answered & (ack == AckCode.ack_complete)] = Kind.unified
        kind[~answered & (errored | missing)] = Kind.failed
        flags[errored] |= Flag.ack_error
        flags[missing] |= Flag.no_ack
        kind[~answered & broadcast & is_write & ((ack < 0) | (ack == NO_ACK))] = Kind.broadcast

        waiting = (kind < 0) & ~answered
        expired = (now - core["ts"][last] > self.expiry_ns) & (core["time_known"][last] > 0)
        reset = core["epoch"][last] < self._epoch
        reused = found.reused
        ends = waiting & (reused | expired | reset | final)
        flags[ends & reused] |= Flag.label_reused
        flags[ends & ~reused & reset] |= Flag.bus_reset
        flags[ends & ~reused & ~reset & expired] |= Flag.timeout
        flags[ends & final & ~reused & ~reset & ~expired] |= Flag.capture_end
        unknown_write = is_write & (ack < 0)
        kind[ends & retrying] = Kind.failed
        kind[ends & ~retrying & unknown_write] = Kind.posted
        kind[ends & ~retrying & ~unknown_write] = Kind.unanswered
        flags[ends & ~retrying & ~unknown_write] |= Flag.no_response
        kind[answered] = np.where(ack[answered] == AckCode.ack_pending, Kind.split, Kind.answered)
        return kind, flags


class _BatchColumns(Mapping[str, np.ndarray]):
    """Batch-long arrays behind the request (or response) columns, made on first use.

    Header fields are decoded lazily too (:class:`~fw1394.capture.analysis.columns.Fields`),
    so a view that never asks for, say, offsets never extracts them.
    """

    def __init__(self, makers: dict[str, Callable[[], np.ndarray]]) -> None:
        self._makers = makers
        self._made: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._made:
            self._made[name] = self._makers[name]()
        return self._made[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._makers)

    def __len__(self) -> int:
        return len(self._makers)


def _arrays(
    batch: Batch,
    decoded: Decoded,
    acks: np.ndarray,
    ordinal: np.ndarray,
    pkt_ordinal: np.ndarray,
    epoch: np.ndarray,
) -> tuple[_BatchColumns, _BatchColumns]:
    """Batch-long arrays behind every request column, and behind every response column."""
    f = decoded.fields

    def field(name: str) -> Callable[[], np.ndarray]:
        return lambda: f[name]

    def fixed(values: np.ndarray) -> Callable[[], np.ndarray]:
        return lambda: values

    def time_known() -> np.ndarray:
        known: np.ndarray = ((batch.flags & ph.flag_bit("time_unknown")) == 0).astype(I64)
        return known

    own: dict[str, Callable[[], np.ndarray]] = {
        "ordinal": fixed(ordinal),
        "pkt_ordinal": fixed(pkt_ordinal),
        "frame": fixed(batch.frame),
        "ts": fixed(batch.ts_ns),
        "time_known": time_known,
        "epoch": fixed(epoch),
        "generation": fixed(batch.generation),
        "tlabel": field("tlabel"),
        "tcode": fixed(decoded.tcode),
        "ack": fixed(acks),
        "problems": fixed(decoded.problems),
        "bidx": lambda: np.arange(len(batch), dtype=I64),
    }
    makers = own | {f"first_{name}": own[name] for name in ("ordinal", "frame", "ts")}
    for name in ("offset", "data_length", "quadlet_data", "extended_tcode"):
        makers[name] = field(name)
    makers["attempts"] = lambda: np.ones(len(batch), I64)
    makers["busy"] = lambda: IS_RETRY_ACK[acks].astype(I64)
    # Response columns: the same records seen from the response side.
    for name in ("ordinal", "pkt_ordinal", "frame", "ts", "time_known", "tcode", "ack", "bidx"):
        makers[f"resp_{name}"] = own[name]
    makers |= {"rcode": field("rcode"), "resp_data_length": field("data_length")}
    makers |= {"resp_quadlet": field("quadlet_data"), "resp_problems": own["problems"]}
    # A request's requester is its source; a response's requester is its destination.
    requests = makers | {"requester": field("source_id"), "responder": field("destination_id")}
    answers = makers | {"requester": field("destination_id"), "responder": field("source_id")}
    return _BatchColumns(requests), _BatchColumns(answers)


def _carry(requests: _Source, found: pairing.Sequence, chosen: np.ndarray) -> table.Table:
    """Request columns of transactions still open, to be carried to the next batch."""
    out = {}
    first, last = requests.place(found.first[chosen]), requests.place(found.last[chosen])
    for name in REQUEST_COLUMNS:
        out[name] = requests.at(name, first if name.startswith("first_") else last)
    out["attempts"] = found.attempts[chosen]
    out["busy"] = found.busy[chosen]
    out["problems"] = found.problems[chosen]
    out["bidx"] = np.full(len(chosen), -1, I64)  # the batch they came from is gone
    return out
