"""The requester alone, driven by hand: labels, acks, responses, timers, bus resets."""

from __future__ import annotations

import pytest

from fw1394.engine import (
    FailureReason,
    LockCompleted,
    ReadCompleted,
    Requester,
    TransactionFailed,
    UnexpectedAck,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.packets import (
    AckCode,
    BlockReadResponse,
    ExtendedTCode,
    LockResponse,
    QuadletReadRequest,
    QuadletReadResponse,
    RCode,
    Request,
    Retry,
    WriteResponse,
)

HOST, NODE = 0xFFC1, 0xFFC0
PENDING, COMPLETE = AckCode.ack_pending, AckCode.ack_complete


def qresponse(label: int, value: int = 7, source: int = NODE) -> QuadletReadResponse:
    return QuadletReadResponse(
        destination_id=HOST, tlabel=label, source_id=source, quadlet_data=value
    )


def sent(requester: Requester) -> list[Request]:
    """The requester's packets to send, as the requests they are."""
    packets = requester.packets_to_send()
    requests = [packet for packet in packets if isinstance(packet, Request)]
    assert requests == packets
    return requests


def pending_read(requester: Requester, node: int = NODE) -> tuple[int, int]:
    """Start a quadlet read and ack it pending: (transaction, label)."""
    tid = requester.read_quadlet(node, 0, 0.0)
    label = requester.in_flight()[tid][1]
    requester.receive_ack(node, label, PENDING, 0.0)
    return tid, label


# -- labels -----------------------------------------------------------------------------
def test_64_labels_per_destination_then_new_transactions_wait_for_one() -> None:
    requester = Requester(node_id=HOST)
    tids = [requester.read_quadlet(NODE, 0, 0.0) for _ in range(64)]
    assert sorted(label for _, label in requester.in_flight().values()) == list(range(64))
    assert len(sent(requester)) == 64
    waiting = requester.read_quadlet(NODE, 0, 0.0)
    assert waiting not in requester.in_flight()
    assert sent(requester) == []
    assert (requester.outstanding, requester.queued) == (65, 1)
    # Another destination has labels of its own.
    other = requester.read_quadlet(0xFFC2, 0, 0.0)
    assert requester.in_flight()[other] == (0xFFC2, 0)
    sent(requester)
    # An error ack is the node's answer: the label is held only for the duplicate
    # window (here none), and the waiting transaction goes out on it at once.
    requester.duplicate_window = 0.0
    requester.receive_ack(NODE, 5, AckCode.ack_address_error, 0.0)
    assert requester.events()[0] == TransactionFailed(
        tids[5], FailureReason.ack_address_error, detail="ack_address_error"
    )
    assert requester.in_flight()[waiting] == (NODE, 5)
    assert [(p.tlabel, p.destination_id) for p in sent(requester)] == [(5, NODE)]
    assert requester.queued == 0


def test_labels_rotate_instead_of_reusing_the_lowest_free() -> None:
    requester = Requester(node_id=HOST, duplicate_window=0.0)
    labels = []
    for _ in range(70):
        tid = requester.write_quadlet(NODE, 0, 1, 0.0)
        labels.append(requester.in_flight()[tid][1])
        requester.receive_ack(NODE, labels[-1], COMPLETE, 0.0)
    assert labels == [n % 64 for n in range(70)]


def test_labels_are_shared_by_every_bus_alias_of_a_node() -> None:
    requester = Requester(node_id=HOST)
    first = requester.read_quadlet(0xFFC0, 0, 0.0)
    second = requester.read_quadlet(0x0000, 0, 0.0)
    assert requester.in_flight()[first][1] != requester.in_flight()[second][1]


# -- acks -------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("ack", "reason"),
    [
        (AckCode.ack_type_error, FailureReason.ack_type_error),
        (AckCode.ack_data_error, FailureReason.ack_data_error),
        (AckCode.ack_address_error, FailureReason.ack_address_error),
        (AckCode.ack_conflict_error, FailureReason.ack_conflict_error),
        (None, FailureReason.no_ack),
        (0x3, FailureReason.no_ack),  # reserved: treated as no ack at all
    ],
)
def test_error_acks_fail_with_their_names(ack: int | None, reason: FailureReason) -> None:
    requester = Requester(node_id=HOST)
    tid = requester.write_quadlet(NODE, 0, 1, 0.0)
    requester.receive_ack(NODE, 0, ack, 0.0)
    (event,) = requester.events()
    assert isinstance(event, TransactionFailed)
    assert (event.transaction, event.reason) == (tid, reason)
    assert requester.outstanding == 0


def test_ack_complete_to_a_read_is_a_mismatch() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.read_quadlet(NODE, 0, 0.0)
    requester.receive_ack(NODE, 0, COMPLETE, 0.0)
    assert requester.events() == [
        TransactionFailed(
            tid, FailureReason.response_mismatch, detail="ack_complete: no response will follow"
        )
    ]


def test_stray_ack_is_an_event_and_changes_nothing() -> None:
    requester = Requester(node_id=HOST)
    tid, label = pending_read(requester)
    requester.receive_ack(NODE, label, COMPLETE, 0.0)  # duplicate ack
    requester.receive_ack(NODE, 33, PENDING, 0.0)  # nothing has label 33
    assert requester.events() == [
        UnexpectedAck(NODE, label, COMPLETE, "no request is waiting for an ack"),
        UnexpectedAck(NODE, 33, PENDING, "no request is waiting for an ack"),
    ]
    assert requester.receive_response(qresponse(label), 0.0) == COMPLETE
    assert requester.events() == [ReadCompleted(tid, b"\0\0\0\x07")]


def test_busy_retry_with_no_delay_resends_at_once_with_the_same_label() -> None:
    requester = Requester(node_id=HOST, busy_retry_delay=0.0)
    requester.write_quadlet(NODE, 0, 1, 0.0)
    (first,) = sent(requester)
    requester.receive_ack(NODE, 0, AckCode.ack_busy_B, 0.0)
    (again,) = sent(requester)
    assert (again.tlabel, again.retry) == (first.tlabel, Retry.retry_X)
    assert first.retry == Retry.retry_1


def test_ack_tardy_is_retried_like_busy() -> None:
    requester = Requester(node_id=HOST, retry_protocol="dual", busy_retry_delay=0.0)
    requester.write_quadlet(NODE, 0, 1, 0.0)
    sent(requester)
    requester.receive_ack(NODE, 0, AckCode.ack_tardy, 0.0)
    assert sent(requester)[0].retry == Retry.retry_X


# -- responses --------------------------------------------------------------------------
def test_block_read_and_lock_complete_with_their_data() -> None:
    requester = Requester(node_id=HOST)
    read = requester.read_block(NODE, 0, 8, 0.0)
    lock = requester.lock(NODE, 0, ExtendedTCode.fetch_add, b"", b"\0\0\0\1", 0.0)
    for label in (0, 1):
        requester.receive_ack(NODE, label, PENDING, 0.0)
    block = BlockReadResponse(destination_id=HOST, tlabel=0, source_id=NODE, data=bytes(range(8)))
    old = LockResponse(
        destination_id=HOST,
        tlabel=1,
        source_id=NODE,
        extended_tcode=ExtendedTCode.fetch_add,
        data=b"\0\0\0\x09",
    )
    requester.receive_response(block, 0.0)
    requester.receive_response(old, 0.0)
    assert requester.events() == [
        ReadCompleted(read, bytes(range(8))),
        LockCompleted(lock, b"\0\0\0\x09"),
    ]


def test_split_write_completes_with_its_response() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.write_block(NODE, 0, b"abcd", 0.0)
    requester.receive_ack(NODE, 0, PENDING, 0.0)
    assert requester.events() == []
    requester.receive_response(WriteResponse(destination_id=HOST, tlabel=0, source_id=NODE), 0.0)
    assert requester.events() == [WriteCompleted(tid)]


def test_error_rcode_fails_with_the_rcode() -> None:
    requester = Requester(node_id=HOST)
    tid, label = pending_read(requester)
    response = QuadletReadResponse(
        destination_id=HOST, tlabel=label, source_id=NODE, rcode=RCode.resp_type_error
    )
    requester.receive_response(response, 0.0)
    assert requester.events() == [
        TransactionFailed(tid, FailureReason.rcode_error, rcode=RCode.resp_type_error)
    ]


@pytest.mark.parametrize(
    ("response", "detail"),
    [
        (
            WriteResponse(destination_id=HOST, tlabel=0, source_id=NODE),
            "write_response does not answer a read_quadlet_request",
        ),
        (
            BlockReadResponse(destination_id=HOST, tlabel=0, source_id=NODE, data=b"1234"),
            "read_block_response does not answer a read_quadlet_request",
        ),
    ],
)
def test_wrong_tcode_is_a_mismatch(response: WriteResponse, detail: str) -> None:
    requester = Requester(node_id=HOST)
    tid, _ = pending_read(requester)
    requester.receive_response(response, 0.0)
    assert requester.events() == [
        TransactionFailed(tid, FailureReason.response_mismatch, detail=detail)
    ]


def test_wrong_length_is_a_mismatch() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.read_block(NODE, 0, 8, 0.0)
    requester.receive_ack(NODE, 0, PENDING, 0.0)
    short = BlockReadResponse(destination_id=HOST, tlabel=0, source_id=NODE, data=b"1234")
    requester.receive_response(short, 0.0)
    assert requester.events() == [
        TransactionFailed(
            tid,
            FailureReason.response_mismatch,
            detail="4 bytes (data_length 4), expected 8",
        )
    ]


def test_wrong_source_bus_is_a_mismatch() -> None:
    requester = Requester(node_id=HOST)
    tid, label = pending_read(requester, node=0x0140)  # bus 5, node 0
    requester.receive_response(qresponse(label, source=0x01C0), 0.0)  # bus 7, node 0
    assert requester.events() == [
        TransactionFailed(
            tid,
            FailureReason.response_mismatch,
            detail="source 0x01c0 is not the destination 0x0140",
        )
    ]


def test_local_bus_alias_matches() -> None:
    requester = Requester(node_id=HOST)
    tid, label = pending_read(requester, node=0xFFC0)
    requester.receive_response(qresponse(label, source=0x0000), 0.0)  # bus 0, node 0
    assert requester.events() == [ReadCompleted(tid, b"\0\0\0\x07")]


def test_lock_extended_tcode_must_match() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.lock(NODE, 0, ExtendedTCode.compare_swap, b"\0" * 4, b"\1" * 4, 0.0)
    requester.receive_ack(NODE, 0, PENDING, 0.0)
    wrong = LockResponse(
        destination_id=HOST,
        tlabel=0,
        source_id=NODE,
        extended_tcode=ExtendedTCode.mask_swap,
        data=b"\0" * 4,
    )
    requester.receive_response(wrong, 0.0)
    (event,) = requester.events()
    assert isinstance(event, TransactionFailed)
    assert (event.transaction, event.reason) == (tid, FailureReason.response_mismatch)


def test_unsolicited_duplicate_and_early_responses_touch_no_transaction() -> None:
    requester = Requester(node_id=HOST)
    done, done_label = pending_read(requester)
    requester.receive_response(qresponse(done_label), 0.0)
    waiting, waiting_label = pending_read(requester)
    not_acked = requester.read_quadlet(NODE, 0, 0.0)
    not_acked_label = requester.in_flight()[not_acked][1]
    assert requester.events() == [ReadCompleted(done, b"\0\0\0\x07")]

    assert requester.receive_response(qresponse(done_label, value=1), 0.0) == COMPLETE
    assert requester.receive_response(qresponse(40, value=2), 0.0) == COMPLETE
    assert requester.receive_response(qresponse(not_acked_label, value=3), 0.0) == COMPLETE
    duplicate, unsolicited, early = requester.events()
    assert isinstance(duplicate, UnexpectedResponse)
    assert duplicate.ended_transaction == done
    assert "late or duplicate" in duplicate.detail
    assert isinstance(unsolicited, UnexpectedResponse)
    assert unsolicited.ended_transaction is None
    assert "unsolicited" in unsolicited.detail
    assert isinstance(early, UnexpectedResponse)
    assert "waiting for its ack" in early.detail

    assert set(requester.in_flight()) == {waiting, not_acked}
    requester.receive_response(qresponse(waiting_label, value=9), 0.0)
    assert requester.events() == [ReadCompleted(waiting, b"\0\0\0\x09")]


def test_responses_to_other_nodes_and_requests_are_not_ours() -> None:
    requester = Requester(node_id=HOST)
    _, label = pending_read(requester)
    elsewhere = QuadletReadResponse(destination_id=0xFFC7, tlabel=label, source_id=NODE)
    assert requester.receive_response(elsewhere, 0.0) is None
    assert sent(requester)[0].tlabel == label
    # Anything not a response is not the requester's to take.
    request = QuadletReadRequest(destination_id=HOST, source_id=NODE)
    assert requester.receive_response(request, 0.0) is None
    assert requester.events() == []
    assert requester.outstanding == 1


# -- time -------------------------------------------------------------------------------
def test_deadlines_ack_then_split_timeout() -> None:
    requester = Requester(node_id=HOST, ack_timeout=0.05, split_timeout=0.2)
    assert requester.next_deadline() is None
    tid = requester.read_quadlet(NODE, 0, 1.0)
    assert requester.next_deadline() == pytest.approx(1.05)
    requester.handle_timer(1.04)
    assert requester.events() == []
    requester.receive_ack(NODE, 0, PENDING, 1.01)
    assert requester.next_deadline() == pytest.approx(1.21)
    requester.handle_timer(1.2)
    assert requester.events() == []
    requester.handle_timer(1.21)
    assert requester.events() == [
        TransactionFailed(tid, FailureReason.response_timeout, detail="split timeout")
    ]
    assert requester.next_deadline() is None


def test_split_timeout_is_configurable_at_run_time() -> None:
    requester = Requester(node_id=HOST)
    requester.split_timeout = 0.5
    pending_read(requester)
    assert requester.next_deadline() == pytest.approx(0.5)


def test_many_transactions_keep_the_timer_heap_small() -> None:
    requester = Requester(node_id=HOST)
    slow, _ = pending_read(requester, node=0xFFC5)  # stays on top of the heap
    # 2 ms apart: fewer than 64 labels are held after their ends at any time.
    for n in range(5000):
        requester.read_quadlet(NODE, 0, n * 2e-3)
        label = sent(requester)[-1].tlabel
        requester.receive_ack(NODE, label, PENDING, n * 2e-3)
        requester.receive_response(qresponse(label), n * 2e-3)
    assert len(requester._timers) < 600
    assert slow in requester.in_flight()


# -- bus resets -------------------------------------------------------------------------
def test_bus_reset_fails_everything_and_renumbers() -> None:
    requester = Requester(node_id=HOST, generation=4)
    first, _ = pending_read(requester)
    second = requester.write_quadlet(0xFFC2, 0, 1, 0.0)
    broadcast = requester.write_quadlet(0xFFFF, 0, 1, 0.0)
    requester.bus_reset(generation=5, node_id=0xFFC3)
    detail = "bus generation 4 -> 5"
    assert requester.events() == [
        WriteCompleted(broadcast),
        TransactionFailed(first, FailureReason.bus_reset, detail=detail),
        # The write was out with no ack yet: it may have been performed.
        TransactionFailed(
            second,
            FailureReason.bus_reset,
            detail=f"{detail}; outcome unknown: the write may have been performed",
            outcome_unknown=True,
        ),
    ]
    # What is still to be sent: only the broadcast write, already reported complete.
    assert [packet.destination_id for packet in sent(requester)] == [0xFFFF]
    assert requester.next_deadline() is None
    assert (requester.generation, requester.node_id) == (5, 0xFFC3)
    requester.read_quadlet(NODE, 0, 0.0)
    (packet,) = sent(requester)
    assert packet.source_id == 0xFFC3


# -- arguments --------------------------------------------------------------------------
def test_bad_arguments_raise_without_taking_a_label() -> None:
    requester = Requester(node_id=HOST)
    with pytest.raises(ValueError):
        requester.read_quadlet(NODE, 1 << 48, 0.0)
    with pytest.raises(ValueError):
        requester.write_quadlet(NODE, 0, 1 << 32, 0.0)
    with pytest.raises(ValueError):
        requester.read_block(NODE, 0, 1 << 16, 0.0)
    with pytest.raises(ValueError):
        requester.lock(NODE, 0, ExtendedTCode.fetch_add, b"\0" * 4, b"\0" * 4, 0.0)
    with pytest.raises(ValueError):
        requester.lock(NODE, 0, ExtendedTCode.compare_swap, b"\0" * 8, b"\0" * 4, 0.0)
    with pytest.raises(ValueError):
        Requester(retry_protocol="triple")
    assert requester.outstanding == 0
    assert sent(requester) == []
