"""A requester against responders of every policy over a lossy, reordering link.

Hypothesis draws the node policies, the fault model (drop, duplicate, delay,
reorder, corrupt, lost acks), the retry protocol, and a sequence of transactions,
busy spells, clock advances and bus resets. After every step:

* every transaction the requester reported on was started, and ends only once;
* a completed read or lock returns exactly the responder's data; a completed
  unicast write was performed by its node;
* no two outstanding transactions to one node share a label;
* no outstanding transaction is past its deadline (counted from when it went out:
  a transaction started while every label to its node was out of use waits);
* well-behaved responders never cause a response mismatch.

Every reader of a :class:`PatternSpace` sees data that depends only on the node and
the offset (writes are logged, never read back), so a response that reached the
wrong transaction would show.
"""

from __future__ import annotations

from dataclasses import dataclass

import pytest
from hypothesis import settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
)

from fw1394.engine import (
    Event,
    FailureReason,
    LockCompleted,
    ReadCompleted,
    Requester,
    Responder,
    ResponderPolicy,
    TransactionEvent,
    TransactionFailed,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.engine.faults import FaultConfig
from fw1394.engine.loopback import Link
from fw1394.engine.space import AddressError, BusyError, DataError, TypeError1394
from fw1394.packets import AckCode, ExtendedTCode

HOST = 0xFFE0
ABSENT = 0xFFD4  # no node answers there
BROADCAST = 0xFFFF
WRITABLE = range(0x400, 0x800)
BUSY_AT, TYPE_ERROR_AT, DATA_ERROR_AT = 0x900, 0xA00, 0xB00
OFFSETS = [0, 4, 0x3FC, 0x400, 0x7F8, 0x800, BUSY_AT, TYPE_ERROR_AT, DATA_ERROR_AT, 1 << 40]
LOCKS = [
    ExtendedTCode.mask_swap,
    ExtendedTCode.compare_swap,
    ExtendedTCode.fetch_add,
    ExtendedTCode.little_add,
    ExtendedTCode.bounded_add,
    ExtendedTCode.wrap_add,
    ExtendedTCode.vendor_dependent,
]

ACK_TIMEOUT, SPLIT_TIMEOUT, BUSY_DELAY, BUSY_RETRIES = 0.050, 0.100, 0.001, 3
#: The longest a transaction can last (docs/engine.md, "Time").
LIFETIME = (1 + BUSY_RETRIES) * (ACK_TIMEOUT + BUSY_DELAY) + SPLIT_TIMEOUT


def pattern(node: int, offset: int, length: int) -> bytes:
    return bytes((node * 37 + offset + i) * 13 & 0xFF for i in range(length))


class PatternSpace:
    """Reads depend only on (node, offset); writes in WRITABLE are logged, never read."""

    def __init__(self, node: int) -> None:
        self.node = node
        self.writes: list[tuple[int, bytes]] = []

    def _check(self, offset: int, length: int) -> None:
        special = {BUSY_AT: BusyError, TYPE_ERROR_AT: TypeError1394, DATA_ERROR_AT: DataError}
        if offset in special:
            raise special[offset]()
        if offset + length > WRITABLE.stop:
            raise AddressError(f"{offset:#x}")

    def read_quadlet(self, offset: int) -> int:
        self._check(offset, 4)
        return int.from_bytes(pattern(self.node, offset, 4), "big")

    def read_block(self, offset: int, length: int) -> bytes:
        self._check(offset, length)
        return pattern(self.node, offset, length)

    def write_quadlet(self, offset: int, value: int) -> None:
        self.write_block(offset, value.to_bytes(4, "big"))

    def write_block(self, offset: int, data: bytes) -> None:
        self._check(offset, len(data))
        if offset not in WRITABLE:
            raise AddressError(f"{offset:#x} is read-only")
        self.writes.append((offset, data))

    def set_time(self, ticks: int) -> None:
        pass


@dataclass(frozen=True)
class Started:
    kind: str  # "read", "write", "lock"
    destination: int
    offset: int
    length: int
    data: bytes
    time: float


policies = st.builds(
    ResponderPolicy,
    read_mode=st.sampled_from(["concatenated", "split"]),
    write_mode=st.sampled_from(["unified", "split"]),
    bad_crc=st.sampled_from(["drop", "ack_data_error"]),
    write_despite_bad_crc=st.booleans(),
    unsupported_tcode=st.sampled_from(["silent", "ack_type_error"]),
    address_error=st.sampled_from(["ack", "rcode"]),
    drop_bad_header_crc=st.booleans(),
    check_block_write_header_crc=st.booleans(),
    ignore_bus_id=st.booleans(),
    locks=st.booleans(),
)
chances = st.sampled_from([0.0, 0.0, 0.05, 0.3])
faults = st.builds(
    FaultConfig,
    loss=chances,
    duplicate=chances,
    delay=chances,
    reorder=chances,
    corrupt=chances,
    lose_ack=chances,
    delay_seconds=st.sampled_from([0.001, 0.020]),
)


class EngineMachine(RuleBasedStateMachine):
    link: Link
    spaces: dict[int, PatternSpace]

    @initialize(
        node_policies=st.lists(policies, min_size=1, max_size=4),
        fault_model=faults,
        seed=st.integers(0, 2**32 - 1),
        retry_protocol=st.sampled_from(["single", "dual"]),
        split_delay=st.sampled_from([0.0, 0.003, 0.150]),
        report_missing_acks=st.booleans(),
    )
    def build(
        self,
        node_policies: list[ResponderPolicy],
        fault_model: FaultConfig,
        seed: int,
        retry_protocol: str,
        split_delay: float,
        report_missing_acks: bool,
    ) -> None:
        self.spaces = {0xFFC0 + n: PatternSpace(n) for n in range(len(node_policies))}
        responders = [
            Responder(node, space, policy)
            for (node, space), policy in zip(self.spaces.items(), node_policies, strict=True)
        ]
        requester = Requester(
            node_id=HOST,
            split_timeout=SPLIT_TIMEOUT,
            ack_timeout=ACK_TIMEOUT,
            max_busy_retries=BUSY_RETRIES,
            busy_retry_delay=BUSY_DELAY,
            retry_protocol=retry_protocol,
        )
        self.link = Link(
            requester,
            responders,
            faults=fault_model,
            seed=seed,
            split_delay=split_delay,
            report_missing_acks=report_missing_acks,
        )
        self.late_answers = split_delay > SPLIT_TIMEOUT or fault_model.reorder > 0
        self.started: dict[int, Started] = {}
        self.ended: dict[int, Event] = {}
        #: Transactions that waited for a label; tid -> when first seen sent.
        self.waited: set[int] = set()
        self.sent_at: dict[int, float] = {}
        self.generation = 0

    # -- starting transactions ---------------------------------------------------------
    def destination(self, choice: int) -> int:
        nodes = [*self.spaces, ABSENT]
        return nodes[choice % len(nodes)]

    def start(self, kind: str, destination: int, offset: int, data: bytes, length: int) -> None:
        requester, now = self.link.requester, self.link.now
        queued = requester.queued
        if kind == "read" and length < 0:
            tid = requester.read_quadlet(destination, offset, now)
            length = 4
        elif kind == "read":
            tid = requester.read_block(destination, offset, length, now)
        elif kind == "write" and len(data) == 4:
            tid = requester.write_quadlet(destination, offset, int.from_bytes(data), now)
        elif kind == "write":
            tid = requester.write_block(destination, offset, data, now)
        else:
            raise AssertionError(kind)
        self.started[tid] = Started(kind, destination, offset, length, data, now)
        self.note_queued(tid, queued)

    def note_queued(self, tid: int, queued_before: int) -> None:
        requester = self.link.requester
        if requester.queued > queued_before:
            # Every label to the node is in use or held: it waits, and only then goes out.
            labels = [
                label
                for d, label in requester.in_flight().values()
                if d & 0x3F == self.started[tid].destination & 0x3F
            ]
            assert len(labels) < 64 or len(set(labels)) == 64
            self.waited.add(tid)

    @rule(choice=st.integers(0, 7), offset=st.sampled_from(OFFSETS))
    def read_quadlet(self, choice: int, offset: int) -> None:
        self.start("read", self.destination(choice), offset, b"", -1)

    @rule(
        choice=st.integers(0, 7),
        offset=st.sampled_from(OFFSETS),
        length=st.sampled_from([0, 4, 12, 64]),
    )
    def read_block(self, choice: int, offset: int, length: int) -> None:
        self.start("read", self.destination(choice), offset, b"", length)

    @rule(
        choice=st.integers(0, 7),
        offset=st.sampled_from(OFFSETS),
        data=st.binary(min_size=4, max_size=4) | st.binary(min_size=0, max_size=24),
        broadcast=st.booleans(),
    )
    def write(self, choice: int, offset: int, data: bytes, broadcast: bool) -> None:
        destination = BROADCAST if broadcast else self.destination(choice)
        self.start("write", destination, offset, data, len(data))

    @rule(
        choice=st.integers(0, 7),
        offset=st.sampled_from(OFFSETS),
        extended_tcode=st.sampled_from(LOCKS),
        size=st.sampled_from([4, 8]),
        operands=st.binary(min_size=16, max_size=16),
    )
    def lock(
        self, choice: int, offset: int, extended_tcode: int, size: int, operands: bytes
    ) -> None:
        destination, requester, now = self.destination(choice), self.link.requester, self.link.now
        adds = extended_tcode in (ExtendedTCode.fetch_add, ExtendedTCode.little_add)
        argument = b"" if adds else operands[:size]
        queued = requester.queued
        tid = requester.lock(
            destination, offset, extended_tcode, argument, operands[8 : 8 + size], now
        )
        self.started[tid] = Started("lock", destination, offset, size, b"", now)
        self.note_queued(tid, queued)

    @rule(choice=st.integers(0, 7), count=st.integers(1, 80))
    def burst(self, choice: int, count: int) -> None:
        """Many reads at once, past label exhaustion, on a quiet link."""
        # A responder slower than the split timeout, or a packet held back behind
        # everything in flight (reorder), may answer later than any label hold
        # covers (docs/engine.md, "Labels"); with either, labels come round again
        # only on a quiet link, so no burst may outrun them.
        self.link.run()
        self.check()
        destination = self.destination(choice)
        if self.late_answers:  # only labels free now: a held one may still be answered late
            count = min(count, 64 - self.link.requester.labels_taken(destination))
        if count <= 0:
            return
        for n in range(count):
            self.start("read", destination, 4 * (n % 16), b"", -1)
        self.check()
        self.link.run()

    # -- the bus and the clock ---------------------------------------------------------
    @rule(seconds=st.sampled_from([0.0, 0.0005, 0.004, 0.030, 0.120, 0.400]))
    def advance(self, seconds: float) -> None:
        self.link.advance(seconds)

    @rule(
        choice=st.integers(0, 7),
        count=st.integers(1, 5),
        code=st.sampled_from([AckCode.ack_busy_X, AckCode.ack_busy_A, AckCode.ack_busy_B]),
    )
    def busy_spell(self, choice: int, count: int, code: int) -> None:
        for responder in self.link.responders:
            if responder.node_id == self.destination(choice):
                responder.inject_busy(count, code)

    @precondition(lambda self: self.link.requester.outstanding > 0)
    @rule()
    def bus_reset(self) -> None:
        outstanding = set(self.link.requester.in_flight())
        self.generation += 1
        self.link.bus_reset(self.generation)
        self.check()
        for tid in outstanding:
            event = self.ended[tid]
            assert isinstance(event, TransactionFailed)
            assert event.reason is FailureReason.bus_reset
        assert self.link.requester.generation == self.generation

    # -- checks ------------------------------------------------------------------------
    @invariant()
    def check(self) -> None:
        requester = self.link.requester
        for event in requester.events():
            self.check_event(event)
        in_flight = requester.in_flight()
        open_ = set(self.started) - set(self.ended)
        assert set(in_flight) <= open_
        assert requester.outstanding == len(open_)
        assert open_ - set(in_flight) <= self.waited
        labels = [(destination & 0x3F, label) for destination, label in in_flight.values()]
        assert len(labels) == len(set(labels))
        for tid in in_flight:
            if tid in self.waited:
                sent = self.sent_at.setdefault(tid, self.link.now)
            else:
                sent = self.started[tid].time
            assert self.link.now <= sent + LIFETIME + 1e-9

    def check_event(self, event: Event) -> None:
        if isinstance(event, UnexpectedResponse):
            assert event.ended_transaction is None or event.ended_transaction in self.ended
            return
        if not isinstance(event, TransactionEvent):
            return
        tid = event.transaction
        assert tid in self.started, f"event about unknown transaction {tid}"
        assert tid not in self.ended, f"transaction {tid} ended twice"
        self.ended[tid] = event
        started = self.started[tid]
        node = started.destination
        if isinstance(event, ReadCompleted):
            assert started.kind == "read"
            assert event.data == pattern(node - 0xFFC0, started.offset, started.length)
        elif isinstance(event, LockCompleted):
            assert started.kind == "lock"
            assert event.old_value == pattern(node - 0xFFC0, started.offset, started.length)
        elif isinstance(event, WriteCompleted):
            assert started.kind == "write"
            if node != BROADCAST:
                assert (started.offset, started.data) in self.spaces[node].writes
        else:
            assert isinstance(event, TransactionFailed)
            assert event.reason is not FailureReason.response_mismatch, event
            if node == ABSENT:
                assert event.reason in (FailureReason.no_ack, FailureReason.bus_reset)

    def teardown(self) -> None:
        if not hasattr(self, "link"):
            return
        self.link.run()
        self.check()
        assert self.link.requester.outstanding == 0
        assert set(self.ended) == set(self.started)


pytestmark = pytest.mark.slow  # hundreds of generated programs, all in process

EngineMachine.TestCase.settings = settings(max_examples=300, stateful_step_count=30, deadline=None)
test_engine_state_machine = EngineMachine.TestCase
