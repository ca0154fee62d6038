"""Labels: no answer completes a transaction it does not belong to.

A requester and a memory node are driven by hand over a medium that drops,
duplicates and delays every packet (requests, acks, responses) as Hypothesis
decides; every completed read must return the value of its own address. Then the
rules one by one: a label is held after its transaction ends, a bus reset frees
it, transactions wait (in order) while every label to their node is held, and a
write or lock that got no answer is reported as of unknown outcome.
"""

from __future__ import annotations

import heapq
import itertools
from dataclasses import dataclass, field
from typing import cast

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import (
    IEEE1394_NODE,
    THESIS_FPGA,
    FailureReason,
    ReadCompleted,
    Requester,
    Responder,
    ResponderPolicy,
    TransactionEvent,
    TransactionFailed,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.packets import AckCode, AsyncPacket, ExtendedTCode, QuadletReadResponse, Request
from fw1394.transport.bus_host import TransactionError

HOST, NODE = 0xFFC1, 0xFFC0
QUADLETS = 1024
SPLIT, ACK = 0.100, 0.050
PENDING, COMPLETE = AckCode.ack_pending, AckCode.ack_complete
#: How long the medium may hold a packet, and how long the node may take to answer
#: a split read. Twice the one plus the other stays within the split timeout, the
#: time a label is held after its transaction got its answer: the longest a
#: copy of that answer may trail it is two trips and an answer.
DELAYS = (0.0, 0.0005, 0.004, 0.025)
ANSWER_TIMES = (0.0, 0.003, 0.050)
# Built once: a strategy made anew for every draw is validated and labelled anew,
# which was most of this test's time.
COPIES_OF = st.sampled_from([0, 1, 1, 1, 2, 3])
DELAY_OF = st.sampled_from(DELAYS)
ANSWER_TIME_OF = st.sampled_from(ANSWER_TIMES)
QUADLET_OF = st.integers(0, QUADLETS - 1)


def value_at(quadlet: int) -> int:
    return (quadlet * 0x9E3779B1 + 0x01234567) & 0xFFFFFFFF


def memory() -> MemorySpace:
    contents = b"".join(value_at(q).to_bytes(4, "big") for q in range(QUADLETS))
    return MemorySpace(4 * QUADLETS, contents=contents)


@dataclass(order=True)
class Arrival:
    time: float
    order: int
    #: "request" (to the node), "ack" or "response" (to the requester).
    kind: str = field(compare=False)
    item: object = field(compare=False)


class Medium:
    """Packets on their way, each copy at the time Hypothesis chose for it."""

    def __init__(self, draw: st.DataObject) -> None:
        self.draw = draw
        self.queue: list[Arrival] = []
        self.order = itertools.count()

    def send(self, now: float, kind: str, item: object, answer_time: float = 0.0) -> None:
        copies = self.draw.draw(COPIES_OF, label=f"{kind} copies")
        for _ in range(copies):
            delay = self.draw.draw(DELAY_OF, label=f"{kind} delay")
            when = now + answer_time + delay
            heapq.heappush(self.queue, Arrival(when, next(self.order), kind, item))


class Bench:
    """One requester, one memory node, the medium between them, and what came of it."""

    def __init__(self, draw: st.DataObject, policy: ResponderPolicy) -> None:
        self.requester = Requester(node_id=HOST, split_timeout=SPLIT, ack_timeout=ACK)
        self.node = Responder(NODE, memory(), policy)
        self.medium = Medium(draw)
        self.draw = draw
        self.now = 0.0
        self.read_of: dict[int, int] = {}
        self.ended: dict[int, TransactionEvent] = {}
        self.unexpected = 0

    def start_reads(self, count: int) -> None:
        for _ in range(count):
            quadlet = self.draw.draw(QUADLET_OF, label="quadlet")
            self.read_of[self.requester.read_quadlet(NODE, 4 * quadlet, self.now)] = quadlet
        self.flush()

    def flush(self) -> None:
        for packet in self.requester.packets_to_send():
            self.medium.send(self.now, "request", packet)
        for event in self.requester.events():
            if isinstance(event, TransactionEvent):
                assert event.transaction not in self.ended
                self.ended[event.transaction] = event
            elif isinstance(event, UnexpectedResponse):
                self.unexpected += 1

    def step(self) -> bool:
        """Deliver the next packet or fire the next timer; ``False``: nothing left."""
        deadline = self.requester.next_deadline()
        queue = self.medium.queue
        if queue and (deadline is None or queue[0].time <= deadline):
            arrival = heapq.heappop(queue)
            self.now = max(self.now, arrival.time)
            self.deliver(arrival)
        elif deadline is not None:
            self.now = max(self.now, deadline)
            self.requester.handle_timer(self.now)
        else:
            return False
        self.flush()
        return True

    def run(self, until: float | None = None) -> None:
        while until is None or self.next_time() <= until:
            if not self.step():
                break
        if until is not None:
            self.now = max(self.now, until)

    def next_time(self) -> float:
        deadline = self.requester.next_deadline()
        times = [t for t in (deadline, self.medium.queue[0].time if self.medium.queue else None)]
        return min((t for t in times if t is not None), default=float("inf"))

    def deliver(self, arrival: Arrival) -> None:
        if arrival.kind == "request":
            request = arrival.item
            assert isinstance(request, Request)
            reply = self.node.receive_packet(request, self.now)
            if reply.ack is not None:
                self.medium.send(self.now, "ack", (request.tlabel, reply.ack))
            if reply.response is not None:
                answer = 0.0
                if not reply.concatenated:
                    answer = self.draw.draw(ANSWER_TIME_OF, label="answer time")
                self.medium.send(self.now, "response", reply.response, answer)
        elif arrival.kind == "ack":
            label, code = cast(tuple[int, int], arrival.item)
            self.requester.receive_ack(NODE, label, code, self.now)
        else:
            assert isinstance(arrival.item, AsyncPacket)
            self.requester.receive_response(arrival.item, self.now)


@settings(
    max_examples=60,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large],
)
@given(
    draw=st.data(),
    policy=st.sampled_from([THESIS_FPGA, IEEE1394_NODE]),
    rounds=st.lists(
        st.tuples(st.integers(0, 60), st.sampled_from([0.0005, 0.005, 0.03, 0.25])),
        min_size=1,
        max_size=6,
    ),
)
def test_no_read_returns_another_addresss_data(
    draw: st.DataObject, policy: ResponderPolicy, rounds: list[tuple[int, float]]
) -> None:
    bench = Bench(draw, policy)
    for count, seconds in rounds:
        # At most 60 outstanding, as a host keeps them: the requester never runs
        # out of labels merely because too much was asked at once.
        bench.start_reads(min(count, 60 - bench.requester.outstanding))
        bench.run(until=bench.now + seconds)
    bench.run()
    assert bench.requester.outstanding == 0
    assert set(bench.ended) == set(bench.read_of)
    wrong = [
        (tid, bench.read_of[tid], event.data.hex())
        for tid, event in bench.ended.items()
        if isinstance(event, ReadCompleted)
        and int.from_bytes(event.data, "big") != value_at(bench.read_of[tid])
    ]
    assert wrong == []
    for event in bench.ended.values():
        if not isinstance(event, ReadCompleted):
            assert isinstance(event, TransactionFailed)
            assert event.reason in (FailureReason.no_ack, FailureReason.response_timeout)
            assert not event.outcome_unknown  # reads have no side effects to be unsure of


# -- the rules one by one ---------------------------------------------------------------
def sent(requester: Requester) -> list[Request]:
    packets = requester.packets_to_send()
    assert all(isinstance(p, Request) for p in packets)
    return packets  # type: ignore[return-value]


def response(label: int, value: int) -> QuadletReadResponse:
    return QuadletReadResponse(
        destination_id=HOST, tlabel=label, source_id=NODE, quadlet_data=value
    )


def fill_labels(requester: Requester, now: float = 0.0, unacked: int = -1) -> list[int]:
    """64 reads to NODE, acked pending but ``unacked``: their ids, label n for the n-th."""
    tids = [requester.read_quadlet(NODE, 4 * n, now) for n in range(64)]
    for request in sent(requester):
        if request.tlabel != unacked:
            requester.receive_ack(NODE, request.tlabel, PENDING, now)
    assert [requester.in_flight()[tid][1] for tid in tids] == list(range(64))
    return tids


def test_a_label_that_got_no_answer_is_held_for_twice_the_split_timeout() -> None:
    requester = Requester(node_id=HOST, split_timeout=SPLIT, ack_timeout=ACK)
    tids = fill_labels(requester, unacked=9)
    requester.receive_ack(NODE, 9, None, 0.010)  # request 9's ack never came
    (failed,) = requester.events()
    assert failed == TransactionFailed(tids[9], FailureReason.no_ack, detail="no ack")
    waiting = requester.read_quadlet(NODE, 0x40, 0.011)
    assert sent(requester) == []
    assert (requester.queued, waiting in requester.in_flight()) == (1, False)
    # The other reads time out at the split timeout; their labels are held too.
    requester.handle_timer(SPLIT)
    assert len(requester.events()) == 63
    assert requester.next_deadline() == pytest.approx(0.010 + 2 * SPLIT)
    requester.handle_timer(0.010 + 2 * SPLIT - 1e-6)
    assert sent(requester) == []
    # A late answer to the failed read meets no transaction on its label.
    assert requester.receive_response(response(9, 0xBAD), 0.2) == COMPLETE
    (late,) = requester.events()
    assert isinstance(late, UnexpectedResponse) and late.ended_transaction == tids[9]
    requester.handle_timer(0.010 + 2 * SPLIT)
    (request,) = sent(requester)
    assert (request.tlabel, request.offset) == (9, 0x40)
    assert requester.in_flight()[waiting] == (NODE, 9)
    # Its ack timeout runs from when it went out, not from when it was started.
    assert requester.next_deadline() == pytest.approx(0.010 + 2 * SPLIT + ACK)


def test_a_label_that_got_its_answer_is_held_for_the_duplicate_window() -> None:
    requester = Requester(node_id=HOST, split_timeout=SPLIT, duplicate_window=0.020)
    tids = fill_labels(requester)
    requester.receive_response(response(3, 0x33), 0.001)
    assert requester.events() == [ReadCompleted(tids[3], (0x33).to_bytes(4, "big"))]
    waiting = requester.read_quadlet(NODE, 0x80, 0.002)
    assert requester.queued == 1
    # A copy of the answer, while the label is held, completes nothing.
    requester.receive_response(response(3, 0x33), 0.015)
    (copy,) = requester.events()
    assert isinstance(copy, UnexpectedResponse) and copy.ended_transaction == tids[3]
    assert requester.next_deadline() == pytest.approx(0.021)
    requester.handle_timer(0.021)
    assert [r.tlabel for r in sent(requester)] == [3]
    requester.receive_ack(NODE, 3, PENDING, 0.022)
    requester.receive_response(response(3, 0x80), 0.023)
    assert requester.events() == [ReadCompleted(waiting, (0x80).to_bytes(4, "big"))]


def test_the_duplicate_window_defaults_to_the_split_timeout_and_zero_frees_at_once() -> None:
    requester = Requester(node_id=HOST, split_timeout=0.3)
    fill_labels(requester)
    requester.receive_response(response(0, 1), 0.0)
    requester.read_quadlet(NODE, 0, 0.0)
    assert requester.next_deadline() == pytest.approx(0.3)
    quick = Requester(node_id=HOST, duplicate_window=0.0)
    fill_labels(quick)
    quick.receive_response(response(0, 1), 0.0)
    quick.read_quadlet(NODE, 0, 0.0)
    assert [r.tlabel for r in sent(quick)] == [0]


def test_waiting_transactions_go_out_in_order_as_labels_come_free() -> None:
    requester = Requester(node_id=HOST, duplicate_window=0.0)
    tids = fill_labels(requester)
    first = requester.write_quadlet(NODE, 0x100, 1, 0.0)
    second = requester.read_quadlet(NODE, 0x104, 0.0)
    assert requester.queued == 2
    assert requester.next_deadline() == pytest.approx(SPLIT)  # only the reads' timers
    requester.receive_response(response(40, 0), 0.001)
    requester.receive_response(response(41, 0), 0.002)
    assert [(r.tlabel, r.offset) for r in sent(requester)] == [(40, 0x100), (41, 0x104)]
    assert requester.in_flight()[first] == (NODE, 40)
    assert requester.in_flight()[second] == (NODE, 41)
    assert [type(e) for e in requester.events()] == [ReadCompleted, ReadCompleted]
    assert requester.outstanding == 64
    assert tids[40] not in requester.in_flight()


def test_a_bus_reset_frees_held_labels_and_fails_waiting_transactions_unsent() -> None:
    requester = Requester(node_id=HOST, split_timeout=SPLIT)
    fill_labels(requester)
    waiting = requester.write_quadlet(NODE, 0, 5, 0.0)
    requester.handle_timer(SPLIT)  # every read times out; all 64 labels are held
    assert len(requester.events()) == 64
    assert requester.queued == 1
    requester.bus_reset(generation=1)
    (failed,) = requester.events()
    # Never sent, so certainly not performed.
    assert failed == TransactionFailed(
        waiting, FailureReason.bus_reset, detail="bus generation 0 -> 1"
    )
    assert sent(requester) == []
    again = requester.read_quadlet(NODE, 0, SPLIT)
    assert [r.tlabel for r in sent(requester)] == [0]
    assert requester.in_flight()[again] == (NODE, 0)
    assert requester.queued == 0


def test_other_destinations_are_not_held_up() -> None:
    requester = Requester(node_id=HOST)
    fill_labels(requester)
    requester.read_quadlet(NODE, 0, 0.0)
    other = requester.read_quadlet(0xFFC2, 0, 0.0)
    assert [r.destination_id for r in sent(requester)] == [0xFFC2]
    assert requester.in_flight()[other] == (0xFFC2, 0)


# -- unknown outcome ----------------------------------------------------------------------
def test_a_write_without_its_ack_may_have_been_performed() -> None:
    requester = Requester(node_id=HOST, ack_timeout=ACK)
    tid = requester.write_quadlet(NODE, 0, 1, 0.0)
    requester.handle_timer(ACK)
    (event,) = requester.events()
    assert event == TransactionFailed(
        tid,
        FailureReason.no_ack,
        detail="ack timeout; outcome unknown: the write may have been performed",
        outcome_unknown=True,
    )
    assert "outcome unknown" in str(TransactionError(event))


def test_a_lock_without_its_response_may_have_been_performed() -> None:
    requester = Requester(node_id=HOST, split_timeout=SPLIT)
    tid = requester.lock(NODE, 0, ExtendedTCode.fetch_add, b"", bytes(4), 0.0)
    requester.receive_ack(NODE, 0, PENDING, 0.0)
    requester.handle_timer(SPLIT)
    (event,) = requester.events()
    assert isinstance(event, TransactionFailed) and event.transaction == tid
    assert (event.reason, event.outcome_unknown) == (FailureReason.response_timeout, True)
    assert "the lock may have been performed" in str(TransactionError(event))


@pytest.mark.parametrize(
    ("ack", "reason"),
    [
        (AckCode.ack_address_error, FailureReason.ack_address_error),
        (AckCode.ack_data_error, FailureReason.ack_data_error),
    ],
)
def test_a_write_the_node_refused_is_not_of_unknown_outcome(
    ack: int, reason: FailureReason
) -> None:
    requester = Requester(node_id=HOST)
    requester.write_quadlet(NODE, 0, 1, 0.0)
    requester.receive_ack(NODE, 0, ack, 0.0)
    (event,) = requester.events()
    assert isinstance(event, TransactionFailed)
    assert (event.reason, event.outcome_unknown) == (reason, False)
    assert "outcome unknown" not in str(TransactionError(event))


def test_a_read_without_its_ack_is_not_flagged() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.read_quadlet(NODE, 0, 0.0)
    requester.receive_ack(NODE, 0, None, 0.0)
    assert requester.events() == [TransactionFailed(tid, FailureReason.no_ack, detail="no ack")]


def test_a_write_that_completed_is_plainly_complete() -> None:
    requester = Requester(node_id=HOST)
    tid = requester.write_quadlet(NODE, 0, 1, 0.0)
    requester.receive_ack(NODE, 0, COMPLETE, 0.0)
    assert requester.events() == [WriteCompleted(tid)]
