"""Requests, acks and responses joined into transactions, and everything that can go wrong."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import pytest

from fw1394.capture.analysis.columns import decode
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.analysis.transaction_model import Flag, Kind
from fw1394.capture.analysis.transactions import Pairer, Transactions
from fw1394.capture.formats import batch as batches
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    encode,
)

HOST, NODE = 0xFFC1, 0xFFC0
A = AckCode


def qread(tl: int, node: int = NODE) -> bytes:
    return encode(QuadletReadRequest(destination_id=node, source_id=HOST, tlabel=tl, offset=4))


def qresp(tl: int, node: int = NODE, value: int = 7) -> bytes:
    return encode(
        QuadletReadResponse(destination_id=HOST, source_id=node, tlabel=tl, quadlet_data=value)
    )


def record(time_us: int, raw: bytes, ack: int | None, generation: int = 1) -> BusRecord:
    return BusRecord(time_us * 1000, RecordType.async_packet, raw, generation, ack=ack)


def reset(time_us: int, generation: int) -> BusRecord:
    return BusRecord(time_us * 1000, RecordType.bus_reset, b"", generation)


def pair(records: Sequence[BusRecord], batch_size: int | None = None) -> list[dict[str, int]]:
    """Every transaction, as {column: value} dicts in order of first frame."""
    pairer = Pairer()
    size = batch_size or max(len(records), 1)
    ended: list[Transactions] = []
    for start in range(0, len(records), size):
        part = records[start : start + size]
        batch = batches.from_records(part, list(range(start + 1, start + 1 + len(part))))
        ended += pairer.feed(batch, decode(batch))
    ended += pairer.finish()
    rows = []
    for tx in ended:
        table = tx.as_table()
        rows += [{k: int(v[i]) for k, v in table.items()} for i in range(len(tx))]
    return sorted(rows, key=lambda row: (row["first_frame"], row["resp_frame"]))


def test_split_transaction_and_its_latency() -> None:
    (tx,) = pair(
        [
            record(0, qread(1), A.ack_pending),
            record(5, qread(2, 0xFFC2), None),
            record(30, qresp(1), A.ack_complete),
        ]
    )[:1]
    assert tx["kind"] == Kind.split
    assert tx["latency_ns"] == 30_000
    assert (tx["first_frame"], tx["resp_frame"]) == (1, 3)
    assert tx["resp_quadlet"] == 7 and tx["flags"] == 0


def test_concatenated_transaction() -> None:
    (tx,) = pair([record(0, qread(1), A.ack_pending), record(2, qresp(1), A.ack_complete)])
    assert tx["kind"] == Kind.concatenated


def test_unified_write() -> None:
    write = encode(QuadletWriteRequest(destination_id=NODE, source_id=HOST, tlabel=4, offset=0))
    (tx,) = pair([record(0, write, A.ack_complete)])
    assert tx["kind"] == Kind.unified and tx["resp_frame"] == -1


def test_busy_retries_join_one_transaction() -> None:
    rows = pair(
        [
            record(0, qread(1), A.ack_busy_X),
            record(10, qread(1), A.ack_busy_X),
            record(20, qread(1), A.ack_pending),
            record(25, qresp(1), A.ack_complete),
        ]
    )
    (tx,) = rows
    assert tx["attempts"] == 3 and tx["busy"] == 2
    assert tx["flags"] & Flag.busy and tx["kind"] == Kind.concatenated
    assert tx["latency_ns"] == 25_000  # from the first attempt


def test_label_reused_before_any_answer() -> None:
    first, second = pair(
        [
            record(0, qread(5), A.ack_pending),
            record(50, qread(5), A.ack_pending),
            record(60, qresp(5), A.ack_complete),
        ]
    )
    assert first["kind"] == Kind.unanswered
    assert first["flags"] & Flag.no_response and first["flags"] & Flag.label_reused
    assert second["resp_frame"] == 3


def test_bus_reset_cancels_outstanding_requests() -> None:
    (tx, stray) = pair(
        [
            record(0, qread(1), A.ack_pending),
            reset(10, 2),
            record(20, qresp(1), A.ack_complete, generation=2),
        ]
    )
    assert tx["kind"] == Kind.unanswered and tx["flags"] & Flag.bus_reset
    assert stray["kind"] == Kind.unsolicited and stray["flags"] & Flag.unsolicited


def test_response_without_request() -> None:
    (tx,) = pair([record(0, qresp(9), A.ack_complete)])
    assert tx["kind"] == Kind.unsolicited and tx["tcode"] == -1


def test_tcode_and_length_mismatches() -> None:
    block = encode(BlockReadRequest(destination_id=NODE, source_id=HOST, tlabel=3, data_length=16))
    short = block_response(3)
    (tx,) = pair([record(0, block, A.ack_pending), record(9, short, A.ack_complete)])
    assert tx["flags"] & Flag.length_mismatch
    wrong_kind = block_response(2)
    (tx,) = pair([record(0, qread(2), A.ack_pending), record(9, wrong_kind, A.ack_complete)])
    assert tx["flags"] & Flag.tcode_mismatch


def block_response(tl: int) -> bytes:
    return encode(BlockReadResponse(destination_id=HOST, source_id=NODE, tlabel=tl, data=bytes(8)))


def test_crc_errors_are_flagged() -> None:
    bad = bytearray(qresp(1))
    bad[-1] ^= 1
    (tx,) = pair([record(0, qread(1), A.ack_pending), record(9, bytes(bad), A.ack_complete)])
    assert tx["flags"] & Flag.crc_error


def test_error_and_missing_acks_fail() -> None:
    failed, silent = pair([record(0, qread(1), A.ack_type_error), record(9, qread(2), 0)])
    assert failed["kind"] == Kind.failed and failed["flags"] & Flag.ack_error
    assert silent["kind"] == Kind.failed and silent["flags"] & Flag.no_ack


def test_broadcast_read_answered_by_one_node() -> None:
    request = qread(4, node=0xFFFF)
    (tx,) = pair([record(0, request, None), record(20, qresp(4, node=0xFFC2), None)])
    assert tx["kind"] == Kind.answered and tx["responder"] == 0xFFFF


def test_broadcast_write_needs_no_answer() -> None:
    write = encode(BlockWriteRequest(destination_id=0xFFFF, source_id=HOST, tlabel=1, data=b"abcd"))
    (tx,) = pair([record(0, write, None)])
    assert tx["kind"] == Kind.broadcast and tx["flags"] == 0


def test_separate_ack_records_are_joined() -> None:
    def ack(time_us: int, code: int) -> BusRecord:
        return BusRecord(time_us * 1000, RecordType.ack, bytes([code << 4 | (code ^ 0xF)]), 1)

    (tx,) = pair(
        [
            record(0, qread(1), None),
            ack(1, A.ack_pending),
            record(2, qresp(1), None),
            ack(3, A.ack_complete),
        ]
    )
    assert tx["ack"] == A.ack_pending and tx["resp_ack"] == A.ack_complete
    assert tx["kind"] == Kind.concatenated


def test_waiting_too_long_is_a_timeout() -> None:
    rows = pair(
        [record(0, qread(1), A.ack_pending), record(2_000_000, qread(2), A.ack_pending)],
        batch_size=1,
    )
    assert rows[0]["flags"] & Flag.timeout and rows[0]["kind"] == Kind.unanswered
    assert rows[1]["flags"] & Flag.capture_end


@pytest.mark.parametrize("batch_size", [1, 7, 64])
def test_batches_do_not_change_the_result(batch_size: int) -> None:
    records = list(simulate(1500, Scenario(busy_every=7, lost_every=11, separate_acks=True)))
    # Batch positions differ by construction; and an ack record that starts a new
    # batch cannot reach a response that already closed its transaction.
    local = {"bidx", "resp_bidx", "resp_ack"}

    def comparable(rows: list[dict[str, int]]) -> list[dict[str, int]]:
        return [{k: v for k, v in row.items() if k not in local} for row in rows]

    whole = pair(records)
    assert comparable(pair(records, batch_size)) == comparable(whole)
    kinds = np.bincount([row["kind"] for row in whole], minlength=len(Kind))
    assert kinds[Kind.split] and kinds[Kind.concatenated] and kinds[Kind.unified]
    assert kinds[Kind.unanswered]
