"""The requester's common ends on flat bytes: an ack, and the response behind it.

Most transactions end one of two ways: a read acked ``ack_pending`` with its
response concatenated behind the ack, and a write acked ``ack_complete``. The
general path decodes the response into a packet, walks :data:`~fw1394.engine.table.ON_ACK`,
moves the transaction to awaiting its response, and judges the packet against
it (:func:`~fw1394.engine.transaction.mismatch_of`). :class:`FastEnds` checks
the same conditions on the wire bytes, with response readers generated from the
packet layouts, and ends the transaction through the requester's own
bookkeeping (labels, timers, events), so that the state and the events are
those of the reference.

Anything else (busy and error acks, error rcodes, a response that does not
match, a split response, a duplicate) is declined before anything changes
(``None``) and goes the general way. Tests hold both paths equal with hypothesis.

:func:`concatenated_data` is the check of a read's ack frame on its own, and
:class:`Solo` keeps a lone transaction out of the requester's records while it
goes the common way: together they let a blocking caller
(:mod:`fw1394.transport.express`) run a whole transaction on flat values.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fw1394.crc import crc32
from fw1394.engine.events import ReadCompleted, WriteCompleted
from fw1394.engine.requester import Requester
from fw1394.engine.transaction import AWAIT_ACK, Transaction, same_node
from fw1394.packets import AckCode, AsyncPacket, BlockReadResponse, QuadletReadResponse, Request
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.codegen import compile_function
from fw1394.packets.fast import block_crc, data_block_source
from fw1394.packets.frame import ACK_FRAME_SIZE
from fw1394.packets.nodeid import BROADCAST_PHY

_PENDING = ACK_BYTES[AckCode.ack_pending]
_COMPLETE = ACK_BYTES[AckCode.ack_complete]
#: Reads a response: ``(destination_id, source_id, tlabel, data)``, or None.
Reader = Callable[[bytes], "tuple[int, int, int, bytes] | None"]


def _reader(cls: type[AsyncPacket]) -> Reader:
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
    origin = f"fw1394.engine.fast_requester read {cls.__name__}"
    read: Reader = compile_function(lines, namespace, "read", origin=origin)
    return read


#: response tcode -> (its class, its reader).
_READERS: dict[int, tuple[type[AsyncPacket], Reader]] = {
    int(cls.LAYOUT.tcode): (cls, _reader(cls)) for cls in (QuadletReadResponse, BlockReadResponse)
}
_TCODE_BYTE = 3


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
    :func:`~fw1394.engine.transaction.mismatch_of` and the rcode check of the
    general path ask of a response.
    """
    if payload[0] != _PENDING or len(payload) <= ACK_FRAME_SIZE + _TCODE_BYTE:
        return None
    response = payload[ACK_FRAME_SIZE:]
    kind = _READERS.get(response[_TCODE_BYTE] >> 4)
    if kind is None or kind[0] is not response_class:
        return None
    fields = kind[1](response)
    if fields is None:
        return None
    destination, source, label, data = fields
    if label != payload[1] or (source ^ sender_phy) & 0x3F:
        return None  # the response names another transaction than the ack
    if destination != me and not same_node(destination, me):
        return None
    if source != destination_id and not same_node(source, destination_id):
        return None
    if length >= 0 and len(data) != length:
        return None
    return data


class FastEnds:
    """The common ends of ``requester``'s transactions; see the module docstring."""

    def __init__(self, requester: Requester) -> None:
        self.requester = requester

    def ack(self, sender_phy: int, payload: bytes, now: float) -> int | None:
        """Take an ack frame's ``payload`` from ``sender_phy``.

        Returns the tlabel of a concatenated response it completed (the link acks
        it ack_complete), -1 for a write it completed with the ack alone, or None:
        nothing was done, take the frame the general way.
        """
        size = len(payload)
        if size < ACK_FRAME_SIZE:
            return None
        requester = self.requester
        tlabel = payload[1]
        transaction = requester._by_label.get((sender_phy & 0x3F) << 6 | tlabel)
        if transaction is None or transaction.state != AWAIT_ACK:
            return None
        if size == ACK_FRAME_SIZE:
            if payload[0] != _COMPLETE or transaction.expects_response:
                return None
            done = WriteCompleted(transaction.tid)
            requester._end(transaction, done, now, requester._answered_hold())
            return -1
        data = concatenated_data(
            payload,
            sender_phy,
            transaction.response_class,
            transaction.destination_id,
            transaction.length,
            requester._node_id,
        )
        if data is None:
            return None
        # The general path moves the transaction to awaiting its response first;
        # ending it at once leaves nothing of that step behind.
        event = ReadCompleted(transaction.tid, data)
        requester._end(transaction, event, now, requester._answered_hold())
        return tlabel


class Solo:
    """One transaction at a time on flat values, kept out of the requester while it goes well.

    A blocking caller with nothing else outstanding needs none of the requester's
    records: :meth:`begin` takes the label and the transaction id the general
    path would take; :meth:`finish` ends the transaction as completed, leaving
    the requester as the general path leaves it (labels, holds, the last holder
    of the label, no events). Anything else, :meth:`adopt` makes the transaction
    one of the requester's own, in flight as if started the general way, and
    the general path goes on from there.
    """

    __slots__ = ("key", "label", "requester", "started", "tid")

    def __init__(self, requester: Requester) -> None:
        self.requester = requester
        self.tid = self.key = self.label = 0
        self.started = 0.0

    def begin(self, destination_id: int, now: float) -> int:
        """The label of a transaction to ``destination_id`` sent at ``now``; -1: none.

        -1 when the requester has anything outstanding, when every label to the
        destination is held, or for a broadcast: the general path it is then.
        """
        requester = self.requester
        key = destination_id & 0x3F
        if requester._transactions or key == BROADCAST_PHY:
            return -1
        label = requester._labels.take(key, now)
        if label is None:
            return -1
        self.tid = requester._next_tid
        requester._next_tid = self.tid + 1
        self.key, self.label, self.started = key, label, now
        return label

    def finish(self, now: float) -> None:
        """The transaction got its answer and completed at ``now``."""
        requester = self.requester
        requester._ended[self.key << 6 | self.label] = self.tid
        hold = requester._answered_hold()
        requester._labels.release(self.key, self.label, now + hold if hold > 0 else None)

    def adopt(self, request: Request, length: int, expects_response: bool) -> int:
        """Make the transaction, sent as ``request``, the requester's; its id.

        ``length`` and ``expects_response`` are what the requester's start of that
        kind gives it: the expected data length (-1: not checked), and whether it
        ends with a response rather than an ack.
        """
        requester = self.requester
        transaction = Transaction(self.tid, self.key, self.label, request, length, expects_response)
        requester._transactions[self.tid] = transaction
        requester._await_ack(transaction, self.started)
        return self.tid
