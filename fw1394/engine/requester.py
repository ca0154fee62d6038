"""The host side: start transactions, match acks and responses, report their ends.

Sans-IO: the caller puts :meth:`Requester.packets_to_send` on the wire, hands
back the acks and responses that came, and calls :meth:`Requester.handle_timer`
by :meth:`Requester.next_deadline`. Every transaction ends with exactly one event
(completed, or failed with a :class:`FailureReason`).

A label stays out of use for a while after its transaction ends (see
:mod:`fw1394.engine.labels`); a transaction started while all 64 labels to its
destination are out of use waits in the requester, in order, and goes out
(appears in :meth:`Requester.packets_to_send`) when one comes free.

Most transactions end one of two ways: a read acked ``ack_pending`` with its
response concatenated behind the ack, and a write acked ``ack_complete``.
:meth:`Requester.take_ack_frame` takes an ack frame's bytes as they came and
ends those at once: it checks on the wire bytes what :data:`~fw1394.engine.table.ON_ACK`
and :func:`~fw1394.engine.transaction.mismatch_of` ask of such an end, with
response readers generated from the packet layouts, and hands anything else
(busy and error acks, error rcodes, a response that does not match, a
duplicate) to :meth:`Requester.receive_ack` and :meth:`Requester.receive_response`,
which walk the table. A blocking caller with nothing else outstanding goes
further: :meth:`Requester.begin` gives it the label and transaction id of a
transaction the requester keeps no record of, :func:`concatenated_data` checks
its answer, and :meth:`Requester.finish` ends it; any other answer,
:meth:`Requester.adopt` makes it one of the requester's own. Tests hold these
ends equal to the table's with hypothesis.
"""

from __future__ import annotations

import heapq
import math
from collections import deque
from collections.abc import Callable
from dataclasses import replace
from typing import Any

from fw1394.crc import crc32
from fw1394.engine.events import (
    Event,
    FailureReason,
    ReadCompleted,
    TransactionFailed,
    UnexpectedAck,
    UnexpectedResponse,
    WriteCompleted,
)
from fw1394.engine.labels import LabelPool
from fw1394.engine.table import MISSING_ACK, ON_ACK, RETRY_CODES, Step
from fw1394.engine.transaction import (
    AWAIT_ACK,
    AWAIT_RESPONSE,
    BUSY_WAIT,
    QUEUED,
    Transaction,
    completion,
    mismatch_of,
    same_node,
)
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    ExtendedTCode,
    LockRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    RCode,
    Request,
    Response,
    name_of,
)
from fw1394.packets.ack import ACK_BYTES, ack_code
from fw1394.packets.codegen import compile_function
from fw1394.packets.fast import block_crc, builder, data_block_source, decode_sound
from fw1394.packets.frame import ACK_FRAME_SIZE
from fw1394.packets.layouts import TCODE_BYTE, TCODE_SHIFT
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BASE, node_id, phy_of

#: A waiting transaction's label is -1: its request carries 63 until it has one.
_LABEL_MASK = 0x3F  # not a node ID: tlabels are 6 bits too
_OFFSET_LIMIT = 1 << 48
_LENGTH_LIMIT = 1 << 16
_ACK_COMPLETE = int(AckCode.ack_complete)
_PENDING_BYTE = ACK_BYTES[AckCode.ack_pending]
_COMPLETE_BYTE = ACK_BYTES[AckCode.ack_complete]
_HEAP_SLACK = 256
# Module-level names: looking a member up on an Enum class costs more than a global.
_AWAIT, _COMPLETE, _RETRY = Step.await_response, Step.complete, Step.retry
_RESP_COMPLETE = int(RCode.resp_complete)
# A request per transaction: built straight into the frozen dataclass's slots.
_ROUTE = ("destination_id", "tlabel", "source_id", "offset")
_new_read_quadlet = builder(QuadletReadRequest, *_ROUTE)
_new_read_block = builder(BlockReadRequest, *_ROUTE, "data_length")
_new_write_quadlet = builder(QuadletWriteRequest, *_ROUTE, "quadlet_data")
_new_write_block = builder(BlockWriteRequest, *_ROUTE, "data")
_new_lock = builder(LockRequest, *_ROUTE, "extended_tcode", "data")
#: Ends that leave the request's fate open: its answer may still be on its way.
_UNANSWERED = frozenset(
    {FailureReason.no_ack, FailureReason.response_timeout, FailureReason.response_mismatch}
)
#: Ends after which a write or lock may or may not have been performed.
_UNKNOWN_OUTCOME = _UNANSWERED | {FailureReason.bus_reset}


class Requester:
    """Transactions from one node (``node_id``) to any others; see ``API.md``."""

    def __init__(
        self,
        node_id: int = LOCAL_BASE | 1,
        generation: int = 0,
        split_timeout: float = 0.100,
        ack_timeout: float = 0.050,
        max_busy_retries: int = 3,
        busy_retry_delay: float = 0.001,
        retry_protocol: str = "single",
        duplicate_window: float | None = None,
    ) -> None:
        if retry_protocol not in ("single", "dual"):
            raise ValueError(f"retry_protocol={retry_protocol!r}: expected 'single' or 'dual'")
        self._node_id = node_id
        self._generation = generation
        self.split_timeout = split_timeout
        self.ack_timeout = ack_timeout
        self.max_busy_retries = max_busy_retries
        self.busy_retry_delay = busy_retry_delay
        self.retry_protocol = retry_protocol
        #: How long a label stays out of use after its transaction got its answer,
        #: for a copy of that answer to pass; ``None``: the split timeout; 0 for a
        #: medium that never duplicates. A transaction that ended without its
        #: answer holds its label for twice the split timeout whatever this says.
        self.duplicate_window = duplicate_window
        self._labels = LabelPool()
        #: Destination physical ID -> transactions waiting for a free label, in order.
        self._waiting: dict[int, deque[Transaction]] = {}
        self._next_tid = 1
        self._transactions: dict[int, Transaction] = {}
        #: (destination physical ID << 6 | label) -> the transaction holding it.
        self._by_label: dict[int, Transaction] = {}
        #: Same key -> the last transaction that held it, to explain late responses.
        self._ended: dict[int, int] = {}
        #: (when, transaction id), a heap. A transaction has one live entry, at its
        #: ``queued`` time; see :meth:`_wait`.
        self._timers: list[tuple[float, int]] = []
        self._outbox: list[AsyncPacket] = []
        self._events: list[Event] = []
        #: The transaction :meth:`begin` started: (id, destination key, label, sent at).
        self._begun = (0, 0, 0, 0.0)

    # -- state -------------------------------------------------------------------------
    @property
    def node_id(self) -> int:
        return self._node_id

    @property
    def generation(self) -> int:
        """The bus generation every packet in :meth:`packets_to_send` belongs to."""
        return self._generation

    @property
    def outstanding(self) -> int:
        """Transactions still owed an event, those waiting for a label included."""
        return len(self._transactions)

    @property
    def queued(self) -> int:
        """Transactions not sent yet because every label to their destination is out of use."""
        return sum(len(waiting) for waiting in self._waiting.values())

    def labels_taken(self, destination_id: int) -> int:
        """Labels to ``destination_id`` that are not free: in use, or held after an end."""
        return self._labels.in_use(phy_of(destination_id))

    def in_flight(self) -> dict[int, tuple[int, int]]:
        """Transactions sent and not ended: id -> (destination ID, transaction label)."""
        return {
            tid: (t.destination_id, t.label)
            for tid, t in self._transactions.items()
            if t.label >= 0
        }

    # -- starting transactions ---------------------------------------------------------
    def read_quadlet(self, destination_id: int, offset: int, now: float) -> int:
        _check_offset(offset)
        key, label = self._take_label(destination_id, now)
        request = _new_read_quadlet(destination_id, label & _LABEL_MASK, self._node_id, offset)
        return self._start(key, label, request, -1, True, now)

    def read_block(self, destination_id: int, offset: int, length: int, now: float) -> int:
        _check_offset(offset)
        if not 0 <= length < _LENGTH_LIMIT:
            raise ValueError(f"block length {length} is outside 0..{_LENGTH_LIMIT - 1}")
        key, label = self._take_label(destination_id, now)
        request = _new_read_block(
            destination_id, label & _LABEL_MASK, self._node_id, offset, length
        )
        return self._start(key, label, request, length, True, now)

    def write_quadlet(self, destination_id: int, offset: int, value: int, now: float) -> int:
        _check_offset(offset)
        if not 0 <= value < 1 << 32:
            raise ValueError(f"quadlet value {value:#x} does not fit 32 bits")
        key, label = self._take_label(destination_id, now)
        request = _new_write_quadlet(
            destination_id, label & _LABEL_MASK, self._node_id, offset, value
        )
        return self._start(key, label, request, -1, False, now)

    def write_block(self, destination_id: int, offset: int, data: bytes, now: float) -> int:
        _check_offset(offset)
        if len(data) >= _LENGTH_LIMIT:
            raise ValueError(f"{len(data)} bytes do not fit a block write")
        key, label = self._take_label(destination_id, now)
        request = _new_write_block(
            destination_id, label & _LABEL_MASK, self._node_id, offset, bytes(data)
        )
        return self._start(key, label, request, -1, False, now)

    def lock(
        self,
        destination_id: int,
        offset: int,
        extended_tcode: int,
        argument: bytes,
        data: bytes,
        now: float,
    ) -> int:
        """Start a lock; ``argument`` is empty for fetch_add and little_add."""
        _check_offset(offset)
        without_argument = extended_tcode in (ExtendedTCode.fetch_add, ExtendedTCode.little_add)
        if without_argument and argument:
            raise ValueError("fetch_add and little_add take no argument")
        if not without_argument and len(argument) != len(data):
            raise ValueError("the argument and the data of a lock must be equally long")
        if not 1 <= extended_tcode <= 0xFFFF:
            raise ValueError(f"extended tcode {extended_tcode:#x} is out of range")
        key, label = self._take_label(destination_id, now)
        operands = bytes(argument) + bytes(data)
        request = _new_lock(
            destination_id, label & _LABEL_MASK, self._node_id, offset, extended_tcode, operands
        )
        # The old value is as long as the data operand; vendor-dependent locks may differ.
        length = -1 if extended_tcode == ExtendedTCode.vendor_dependent else len(data)
        return self._start(key, label, request, length, True, now)

    def _take_label(self, destination_id: int, now: float) -> tuple[int, int]:
        """(key, label) for a new transaction; label -1: it has to wait for one."""
        # Keyed by physical ID alone: a response may name the local bus as 0x3FF
        # or by its number, and both must find the transaction.
        key = phy_of(destination_id)
        if key in self._waiting:
            return key, -1  # no overtaking the transactions already waiting
        label = self._labels.take(key, now)
        return key, -1 if label is None else label

    def _start(
        self, key: int, label: int, request: Request, length: int, expects: bool, now: float
    ) -> int:
        tid = self._next_tid
        self._next_tid = tid + 1
        transaction = Transaction(tid, key, label, request, length, expects)
        self._transactions[tid] = transaction
        if label >= 0:
            self._send_first(transaction, now)
        else:
            waiting = self._waiting.setdefault(key, deque())
            waiting.append(transaction)
            if len(waiting) == 1:
                self._wait_for_label(transaction)
        return tid

    def _send_first(self, transaction: Transaction, now: float) -> None:
        self._outbox.append(transaction.request)
        key, label = transaction.key, transaction.label
        if key == BROADCAST_PHY and not transaction.expects_response:
            # Nobody acks a broadcast: the write is complete once it is sent, and
            # no answer will ever use its label.
            self._labels.release(key, label)
            del self._transactions[transaction.tid]
            self._events.append(WriteCompleted(transaction.tid))
            return
        self._await_ack(transaction, now)

    def _await_ack(self, transaction: Transaction, sent: float) -> None:
        """``transaction`` went out at ``sent`` for the first time: its label names it now."""
        self._by_label[transaction.key << 6 | transaction.label] = transaction
        self._wait(transaction, AWAIT_ACK, sent + self.ack_timeout)

    def _wait_for_label(self, head: Transaction) -> None:
        """Set the timer of the first waiting transaction to a destination."""
        free_from = self._labels.free_from(head.key)
        if free_from is not None:
            self._wait(head, QUEUED, free_from)
        else:
            # Every label belongs to a live transaction; the first to end starts
            # this one. Any timer entry it had goes stale.
            head.state, head.deadline, head.queued = QUEUED, math.inf, math.inf

    def _start_waiting(self, key: int, now: float) -> None:
        """Send the transactions waiting for labels to ``key`` that can have one now."""
        waiting = self._waiting[key]
        while waiting:
            label = self._labels.take(key, now)
            if label is None:
                self._wait_for_label(waiting[0])
                return
            transaction = waiting.popleft()
            transaction.label = label
            transaction.request = replace(transaction.request, tlabel=label)
            transaction.queued = math.inf  # its label timer, if any, is stale now
            self._send_first(transaction, now)
        del self._waiting[key]

    # -- output ------------------------------------------------------------------------
    def packets_to_send(self) -> list[AsyncPacket]:
        """Drain the packets to put on the wire, in order."""
        packets, self._outbox = self._outbox, []
        return packets

    def events(self) -> list[Event]:
        """Drain the events that happened since the last call."""
        events, self._events = self._events, []
        return events

    # -- input -------------------------------------------------------------------------
    def receive_ack(
        self, destination_id: int, tlabel: int, ack_code: int | None, now: float
    ) -> None:
        """The ack that followed our request to ``destination_id`` with ``tlabel``.

        ``ack_code=None`` reports that no ack came (the transport saw the ack gap pass).
        """
        key = phy_of(destination_id) << 6 | tlabel
        transaction = self._by_label.get(key)
        if transaction is None or transaction.state != AWAIT_ACK:
            self._events.append(
                UnexpectedAck(destination_id, tlabel, ack_code, "no request is waiting for an ack")
            )
            return
        reaction = (
            MISSING_ACK
            if ack_code is None
            else ON_ACK.get((transaction.expects_response, ack_code), MISSING_ACK)
        )
        step = reaction.step
        if step is _AWAIT:
            self._wait(transaction, AWAIT_RESPONSE, now + self.split_timeout)
        elif step is _COMPLETE:
            self._end(transaction, WriteCompleted(transaction.tid), now, self._answered_hold())
        elif step is _RETRY:
            assert ack_code is not None
            self._retry(transaction, ack_code, now)
        else:
            assert reaction.reason is not None
            detail = reaction.detail or _ack_name(ack_code)
            self._fail(transaction, reaction.reason, now, detail=detail)

    def receive_response(self, packet: AsyncPacket, now: float) -> int | None:
        """Take a response; the ack to send back for it, or ``None`` if it is not ours.

        Any response addressed to this node is acked ack_complete (the link accepts
        it); one that answers no outstanding transaction becomes an
        :class:`UnexpectedResponse` event and touches no transaction.
        """
        if not isinstance(packet, Response):
            return None
        destination = packet.destination_id
        if destination != self._node_id and not same_node(destination, self._node_id):
            return None
        key = phy_of(packet.source_id) << 6 | packet.tlabel
        transaction = self._by_label.get(key)
        if transaction is None or transaction.state != AWAIT_RESPONSE:
            self._unexpected(packet, key, transaction)
            return _ACK_COMPLETE
        mismatch = mismatch_of(transaction, packet)
        if mismatch:
            self._fail(transaction, FailureReason.response_mismatch, now, detail=mismatch)
        elif packet.rcode != _RESP_COMPLETE:
            self._fail(transaction, FailureReason.rcode_error, now, rcode=packet.rcode)
        else:
            self._end(transaction, completion(transaction, packet), now, self._answered_hold())
        return _ACK_COMPLETE

    def _unexpected(self, packet: Response, key: int, transaction: Transaction | None) -> None:
        where = f"node {packet.source_id:#06x} label {packet.tlabel}"
        if transaction is not None:
            waiting = "its ack" if transaction.state == AWAIT_ACK else "a busy retry"
            detail = f"transaction {transaction.tid} to {where} is waiting for {waiting}"
            self._events.append(UnexpectedResponse(packet, detail))
            return
        ended = self._ended.get(key)
        if ended is None:
            detail = f"no transaction to {where} (unsolicited)"
        else:
            detail = f"transaction {ended} to {where} has ended (late or duplicate)"
        self._events.append(UnexpectedResponse(packet, detail, ended))

    # -- the common ends, on flat bytes -------------------------------------------------
    def take_ack_frame(self, sender_phy: int, payload: bytes, now: float) -> int:
        """Take an ack frame's ``payload`` from physical ID ``sender_phy``: the ack, and
        the response of the same tenure if one is behind it.

        Returns the label of a response the link must ack ``ack_complete`` (any
        response addressed to this node is), else -1. A payload too short to name
        a transaction changes nothing.
        """
        size = len(payload)
        if size < ACK_FRAME_SIZE:
            return -1
        tlabel = payload[1]
        transaction = self._by_label.get(phy_of(sender_phy) << 6 | tlabel)
        if transaction is not None and transaction.state == AWAIT_ACK:
            if size == ACK_FRAME_SIZE:
                if payload[0] == _COMPLETE_BYTE and not transaction.expects_response:
                    done = WriteCompleted(transaction.tid)
                    self._end(transaction, done, now, self._answered_hold())
                    return -1
            else:
                data = concatenated_data(
                    payload,
                    sender_phy,
                    transaction.response_class,
                    transaction.destination_id,
                    transaction.length,
                    self._node_id,
                )
                if data is not None:
                    # The table's way moves the transaction to awaiting its response
                    # first; ending it at once leaves nothing of that step behind.
                    event = ReadCompleted(transaction.tid, data)
                    self._end(transaction, event, now, self._answered_hold())
                    return tlabel
        self.receive_ack(node_id(sender_phy), tlabel, ack_code(payload[0]), now)
        if size > ACK_FRAME_SIZE:
            packet = decode_sound(payload[ACK_FRAME_SIZE:])
            if packet is not None and self.receive_response(packet, now) is not None:
                label: int = getattr(packet, "tlabel", 0)
                return label
        return -1

    def begin(self, destination_id: int, now: float) -> int:
        """The label of a transaction to ``destination_id`` sent at ``now``; -1: none.

        For a blocking caller that sends the request itself and checks its answer
        with :func:`concatenated_data`: the requester hands out the label and the
        transaction id a start would, and keeps no record until :meth:`adopt`.
        Then :meth:`finish` or :meth:`adopt`, before anything else. -1 when
        anything is outstanding, when every label to the destination is held,
        or for a broadcast: start the transaction the usual way then.
        """
        key = phy_of(destination_id)
        if self._transactions or key == BROADCAST_PHY:
            return -1
        label = self._labels.take(key, now)
        if label is None:
            return -1
        tid = self._next_tid
        self._next_tid = tid + 1
        self._begun = (tid, key, label, now)
        return label

    def finish(self, now: float) -> None:
        """The transaction of :meth:`begin` got its answer and completed at ``now``.

        The requester is left as the table's way leaves it after that end (the
        label held for the duplicate window, its last holder known), with no event.
        """
        tid, key, label, _ = self._begun
        self._ended[key << 6 | label] = tid
        hold = self._answered_hold()
        self._labels.release(key, label, now + hold if hold > 0 else None)

    def adopt(self, request: Request, length: int, expects_response: bool) -> int:
        """Make the transaction of :meth:`begin`, sent as ``request``, one of the
        requester's own, in flight as if started the usual way; its id.

        ``length`` and ``expects_response`` are what the start of that kind gives
        it: the data length its answer must bring (-1: not checked), and whether
        it ends with a response rather than an ack.
        """
        tid, key, label, sent = self._begun
        transaction = Transaction(tid, key, label, request, length, expects_response)
        self._transactions[tid] = transaction
        self._await_ack(transaction, sent)
        return tid

    # -- time and bus resets -----------------------------------------------------------
    def next_deadline(self) -> float | None:
        """When :meth:`handle_timer` next has something to do; ``None``: nothing pending."""
        self._drop_stale_timers()
        return self._timers[0][0] if self._timers else None

    def handle_timer(self, now: float) -> None:
        """Act on every deadline that has passed at ``now``."""
        timers = self._timers
        while timers and timers[0][0] <= now:
            when, tid = heapq.heappop(timers)
            transaction = self._transactions.get(tid)
            if transaction is None or transaction.queued != when:
                continue  # stale: the transaction ended, or an earlier entry replaced this one
            if transaction.deadline > when:
                # The deadline moved on since this entry was queued: it is due later.
                transaction.queued = transaction.deadline
                heapq.heappush(timers, (transaction.deadline, tid))
                continue
            transaction.queued = math.inf
            state = transaction.state
            if state == AWAIT_ACK:
                self._fail(transaction, FailureReason.no_ack, now, detail="ack timeout")
            elif state == AWAIT_RESPONSE:
                self._fail(transaction, FailureReason.response_timeout, now, detail="split timeout")
            elif state == QUEUED:
                self._start_waiting(transaction.key, now)
            else:
                self._send_again(transaction, now)

    def bus_reset(self, *, generation: int, node_id: int | None = None) -> None:
        """A bus reset: every outstanding transaction fails; new ones use ``generation``.

        The reset voids every answer of the old generation, so every label is free
        again at once, held ones included.
        """
        detail = f"bus generation {self._generation} -> {generation}"
        self._waiting.clear()
        for transaction in list(self._transactions.values()):
            self._fail(transaction, FailureReason.bus_reset, None, detail=detail)
        self._generation = generation
        if node_id is not None:
            self._node_id = node_id
        # Unsent packets of the failed transactions go with them; broadcast writes,
        # already reported complete and addressed to no node ID, still go out.
        self._outbox = [p for p in self._outbox if _is_broadcast_write(p)]
        self._timers.clear()
        self._labels.release_all()

    # -- internals ---------------------------------------------------------------------
    def _wait(self, transaction: Transaction, state: int, deadline: float) -> None:
        transaction.state = state
        transaction.deadline = deadline
        # A later deadline than the one queued needs no heap entry of its own: the
        # queued entry, when it comes up, is moved on to it. Most transactions end
        # before their first deadline, so a read costs one heap entry, not two.
        if deadline < transaction.queued:
            transaction.queued = deadline
            heapq.heappush(self._timers, (deadline, transaction.tid))

    def _retry(self, transaction: Transaction, ack: int, now: float) -> None:
        if transaction.busy >= self.max_busy_retries:
            self._fail(
                transaction,
                FailureReason.busy_retries_exhausted,
                now,
                detail=f"{transaction.busy} retries, then {_ack_name(ack)}",
            )
            return
        transaction.busy += 1
        code = RETRY_CODES[(self.retry_protocol, ack)]
        transaction.request = replace(transaction.request, retry=code)
        if self.busy_retry_delay > 0:
            self._wait(transaction, BUSY_WAIT, now + self.busy_retry_delay)
        else:
            self._send_again(transaction, now)

    def _send_again(self, transaction: Transaction, now: float) -> None:
        self._outbox.append(transaction.request)
        self._wait(transaction, AWAIT_ACK, now + self.ack_timeout)

    def _answered_hold(self) -> float:
        window = self.duplicate_window
        return self.split_timeout if window is None else window

    def _fail(
        self,
        transaction: Transaction,
        reason: FailureReason,
        now: float | None,
        *,
        rcode: int | None = None,
        detail: str = "",
    ) -> None:
        request = transaction.request
        unknown = (
            reason in _UNKNOWN_OUTCOME
            and transaction.state in (AWAIT_ACK, AWAIT_RESPONSE)
            and not isinstance(request, (QuadletReadRequest, BlockReadRequest))
        )
        if unknown:
            kind = "lock" if isinstance(request, LockRequest) else "write"
            detail = f"{detail}; outcome unknown: the {kind} may have been performed"
        # Without its answer, the answer itself may still come: sent as late as the
        # split timeout allows a responder, then delayed as long as the medium may
        # delay a packet (the split timeout again). With it, only a copy may come.
        hold = 2 * self.split_timeout if reason in _UNANSWERED else self._answered_hold()
        event = TransactionFailed(transaction.tid, reason, rcode, detail, unknown)
        self._end(transaction, event, now, hold)

    def _end(self, transaction: Transaction, event: Event, now: float | None, hold: float) -> None:
        """Report ``event``; ``now`` ``None``: a bus reset, which frees every label itself."""
        del self._transactions[transaction.tid]
        self._events.append(event)
        label = transaction.label
        if label < 0:
            return  # never sent
        key = transaction.key << 6 | label
        del self._by_label[key]
        self._ended[key] = transaction.tid
        if now is not None:
            self._labels.release(transaction.key, label, now + hold if hold > 0 else None)
            if transaction.key in self._waiting:
                self._start_waiting(transaction.key, now)
        # Transactions mostly end in the order they started: dropping the stale
        # timers at the top now keeps the heap as small as the work in flight.
        self._drop_stale_timers()
        if len(self._timers) > _HEAP_SLACK + 4 * len(self._transactions):
            # One slow transaction on top can hide many stale entries below it.
            self._timers = [
                entry
                for entry in self._timers
                if (live := self._transactions.get(entry[1])) is not None
                and live.queued == entry[0]
            ]
            heapq.heapify(self._timers)

    def _drop_stale_timers(self) -> None:
        # Leaves the heap's top exact: live, and at its transaction's deadline.
        timers, transactions = self._timers, self._transactions
        while timers:
            when, tid = timers[0]
            transaction = transactions.get(tid)
            if transaction is None or transaction.queued != when:
                heapq.heappop(timers)
            elif transaction.deadline > when:
                transaction.queued = transaction.deadline
                heapq.heapreplace(timers, (transaction.deadline, tid))
            else:
                return


def _is_broadcast_write(packet: AsyncPacket) -> bool:
    return (
        isinstance(packet, (QuadletWriteRequest, BlockWriteRequest))
        and phy_of(packet.destination_id) == BROADCAST_PHY
    )


def _ack_name(ack: int | None) -> str:
    return "no ack" if ack is None else name_of(AckCode, ack)


def _check_offset(offset: int) -> None:
    if not 0 <= offset < _OFFSET_LIMIT:
        raise ValueError(f"offset {offset:#x} does not fit 48 bits")


# -- a concatenated answer, checked on its bytes -----------------------------------------
#: Reads a response: ``(destination_id, source_id, tlabel, data)``, or None.
_Reader = Callable[[bytes], "tuple[int, int, int, bytes] | None"]


def _reader(cls: type[AsyncPacket]) -> _Reader:
    """``(destination_id, source_id, tlabel, data)`` of ``raw``, a sound ``cls``
    response with rcode resp_complete, else None; generated from its layout."""
    layout = cls.LAYOUT
    sealed = layout.sealed_header
    size = 4 * sealed.count
    expressions = sealed.field_expressions()
    quadlets = ", ".join(f"q{i}" for i in range(sealed.count))
    lines = [
        "def read(raw):",
        f"    if len(raw) {'<' if layout.has_data else '!='} {size}:",
        "        return None",
        f"    {quadlets} = unpack_from(raw)",
        f"    if crc(raw[:{size - 4}]) != {expressions['header_crc']} or {expressions['rcode']}:",
        "        return None",
    ]
    if layout.has_data:
        lines += data_block_source(size, expressions["data_length"])
    else:
        lines.append(f"    data = to_bytes({expressions['quadlet_data']}, 4)")
    names = ("destination_id", "source_id", "tlabel")
    lines.append(f"    return {', '.join(expressions[name] for name in names)}, data")
    namespace: dict[str, Any] = {
        "unpack_from": sealed.format.unpack_from,
        "crc": crc32,
        "block_crc": block_crc,
        "from_bytes": int.from_bytes,
        "to_bytes": int.to_bytes,
    }
    origin = f"fw1394.engine.requester read {cls.__name__}"
    read: _Reader = compile_function(lines, namespace, "read", origin=origin)
    return read


#: response tcode -> (its class, its reader).
_READERS: dict[int, tuple[type[AsyncPacket], _Reader]] = {
    int(cls.LAYOUT.tcode): (cls, _reader(cls)) for cls in (QuadletReadResponse, BlockReadResponse)
}


def concatenated_data(
    payload: bytes,
    sender_phy: int,
    response_class: type[AsyncPacket],
    destination_id: int,
    length: int,
    me: int,
) -> bytes | None:
    """The data of a read that ack frame ``payload`` ends, or None.

    ``payload`` from ``sender_phy`` must be ack_pending with a sound
    ``response_class`` response behind it, resp_complete, with the ack's label,
    addressed to node ``me`` by ``destination_id``, the transaction's
    destination, with ``length`` bytes of data (-1: any); what
    :data:`~fw1394.engine.table.ON_ACK`, :func:`~fw1394.engine.transaction.mismatch_of`
    and the rcode check ask of a read that completes.
    """
    if payload[0] != _PENDING_BYTE or len(payload) <= ACK_FRAME_SIZE + TCODE_BYTE:
        return None
    response = payload[ACK_FRAME_SIZE:]
    kind = _READERS.get(response[TCODE_BYTE] >> TCODE_SHIFT)
    if kind is None or kind[0] is not response_class:
        return None
    fields = kind[1](response)
    if fields is None:
        return None
    destination, source, label, data = fields
    if label != payload[1] or phy_of(source) != phy_of(sender_phy):
        return None  # the response names another transaction than the ack
    if destination != me and not same_node(destination, me):
        return None
    if source != destination_id and not same_node(source, destination_id):
        return None
    if length >= 0 and len(data) != length:
        return None
    return data
