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
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from fw1394.crc import crc32
from fw1394.engine.events import ReadCompleted, WriteCompleted
from fw1394.engine.requester import Requester
from fw1394.engine.transaction import AWAIT_ACK, same_node
from fw1394.packets import AckCode, AsyncPacket, BlockReadResponse, QuadletReadResponse
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.fast import block_crc, data_block_source
from fw1394.packets.frame import ACK_FRAME_SIZE

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
    exec("\n".join(lines) + "\n", namespace)
    read: Reader = namespace["read"]
    return read


#: response tcode -> (its class, its reader).
_READERS: dict[int, tuple[type[AsyncPacket], Reader]] = {
    int(cls.LAYOUT.tcode): (cls, _reader(cls)) for cls in (QuadletReadResponse, BlockReadResponse)
}
_TCODE_BYTE = 3


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
        byte, tlabel = payload[0], payload[1]
        transaction = requester._by_label.get((sender_phy & 0x3F) << 6 | tlabel)
        if transaction is None or transaction.state != AWAIT_ACK:
            return None
        if size == ACK_FRAME_SIZE:
            if byte != _COMPLETE or transaction.expects_response:
                return None
            done = WriteCompleted(transaction.tid)
            requester._end(transaction, done, now, requester._answered_hold())
            return -1
        if byte != _PENDING or size <= ACK_FRAME_SIZE + _TCODE_BYTE:
            return None
        response = payload[ACK_FRAME_SIZE:]
        kind = _READERS.get(response[_TCODE_BYTE] >> 4)
        if kind is None or kind[0] is not transaction.response_class:
            return None
        fields = kind[1](response)
        if fields is None:
            return None
        destination, source, label, data = fields
        me = requester._node_id
        if label != tlabel or (source ^ sender_phy) & 0x3F:
            return None  # the response names another transaction than the ack
        if destination != me and not same_node(destination, me):
            return None
        expected = transaction.destination_id
        if source != expected and not same_node(source, expected):
            return None
        if transaction.length >= 0 and len(data) != transaction.length:
            return None
        # The general path moves the transaction to awaiting its response first;
        # ending it at once leaves nothing of that step behind.
        event = ReadCompleted(transaction.tid, data)
        requester._end(transaction, event, now, requester._answered_hold())
        return label
