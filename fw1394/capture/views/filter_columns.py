"""The columns a display filter reads: packets of a batch, or transactions, by field name.

Every column is int64 with -1 where the row has no such field; a field with
two values per row (a transaction's request and response tcode) has two
columns. Columns are built on first use, so a filter on ``tcode`` touches
nothing else.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Mapping

import numpy as np

from fw1394.capture.analysis.columns import Decoded, ack_codes
from fw1394.capture.analysis.transactions import Transactions
from fw1394.capture.formats.batch import Batch
from fw1394.capture.views.display_filter import FIELDS

Builder = Callable[[], tuple[np.ndarray, ...]]


class _Lazy(Mapping[str, tuple[np.ndarray, ...]]):
    def __init__(self, builders: dict[str, Builder]) -> None:
        self._builders = builders
        self._cache: dict[str, tuple[np.ndarray, ...]] = {}

    def __getitem__(self, name: str) -> tuple[np.ndarray, ...]:
        if name not in self._cache:
            self._cache[name] = tuple(np.asarray(c, np.int64) for c in self._builders[name]())
        return self._cache[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._builders)

    def __len__(self) -> int:
        return len(self._builders)


#: Filter names whose packet column is the decoder's header field of another name.
_HEADER_FIELDS = {"src": "source_id", "dst": "destination_id"}
_PACKET_HEADER_FIELDS: tuple[str, ...] = ("src", "dst", "tlabel", "retry", "priority", "offset")
_PACKET_HEADER_FIELDS += ("rcode", "data_length", "extended_tcode", "quadlet_data", "channel")
_PACKET_HEADER_FIELDS += ("tag", "sy")


def packet_columns(batch: Batch, decoded: Decoded, origin_ns: int) -> _Lazy:
    """Filter columns of every record of ``batch``."""

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
    }
    assert set(builders) <= set(FIELDS)
    return _Lazy(builders)
