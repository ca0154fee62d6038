"""Sorting the frames that come back from a node into replies, packet by packet.

Over fw1394's tunnel (``docs/virtual-bus.md``) an ack names the sequence
number of the frame it acknowledges, and may carry a concatenated response;
a split response comes later as a packet of its own and is matched by its
transaction label. Over Eth1394 there are no acks: a response is matched by
label, kind (the response tcode its request gets) and requester, in order; one
that answers no request of the batch is a late answer to an earlier batch and
is counted as such, never taken for a later request's. Either way the batch is
complete once its last packet (the fence) has its whole reply.
"""

from __future__ import annotations

from fw1394.fuzz.target import Observation, Wire
from fw1394.packets import AckCode
from fw1394.packets.asynchronous import tcode_of
from fw1394.packets.enums import TCode
from fw1394.packets.fast import FIELD_NAMES
from fw1394.packets.tcodes import RESPONSE_OF_REQUEST
from fw1394.transport.sansio.wire import FrameError, parse_ack


def answer_of(raw: bytes, *, request: bool) -> tuple[int, int] | None:
    """(response tcode, requester ID) of the answer to the request in ``raw``, or, with
    ``request=False``, of the response in ``raw``; None where there is none to read.

    Read from the first two quadlets, which every asynchronous packet has, so a
    request cut short (a node may still answer it) is matched too.
    """
    if len(raw) < 8 or tlabel_of(raw) is None:
        return None
    tcode = tcode_of(raw)
    if request:
        return RESPONSE_OF_REQUEST.get(TCode(tcode), -1), int.from_bytes(raw[4:6], "big")
    return tcode, int.from_bytes(raw[0:2], "big")


def tlabel_of(raw: bytes) -> int | None:
    """The transaction label of the packet in ``raw`` (None: no header to read it from)."""
    if len(raw) < 4:
        return None
    names = FIELD_NAMES.get(tcode_of(raw))
    if names is None or "tlabel" not in names:
        return None
    return raw[2] >> 2  # quadlet 0 bits 15..10, in every packet that has a label


class Replies:
    """What came back for each packet of one batch."""

    def __init__(self, batch: list[Wire], sequences: list[int] | None = None) -> None:
        count = len(batch)
        self._index = {s: i for i, s in enumerate(sequences or ())}
        self._tlabels = [tlabel_of(wire.raw) for wire in batch]
        self._answers = [answer_of(wire.raw, request=True) for wire in batch]
        #: Responses that answer no request of the batch (late answers to earlier ones).
        self.late = 0
        self.acks: list[int | None] = [None] * count
        self.responses: list[bytes | None] = [None] * count
        self.concatenated = [False] * count
        self._last_acked = -1

    def on_ack(self, payload: bytes) -> None:
        try:
            ack = parse_ack(payload)
        except FrameError:
            return
        index = self._index.get(ack.acked_sequence)
        if index is None:
            return  # an ack of an earlier batch, come too late
        self.acks[index] = ack.code
        self._last_acked = max(self._last_acked, index)
        if ack.concatenated:
            self.responses[index] = ack.concatenated
            self.concatenated[index] = True

    def on_response(self, raw: bytes, *, acked: bool = True) -> None:
        """A response on its own: it answers the first open request with its label.

        ``acked``: the transport has acks (fw1394's tunnel), so a split response
        answers a request already acked, and one with a label no such request
        has goes to the latest of them. Without acks (Eth1394) the label is all
        there is: a response matching no open request is a late answer to an
        earlier batch and is dropped.
        """
        last = self._last_acked if acked else len(self.responses) - 1
        open_ = [i for i in range(last + 1) if self.responses[i] is None]
        tlabel = tlabel_of(raw)
        matching = [i for i in open_ if self._tlabels[i] == tlabel]
        if not acked:
            # The label is 6 bits: the kind of answer and whom it is for must fit too.
            answer = answer_of(raw, request=False)
            matching = [i for i in matching if self._answers[i] == answer]
        if matching:
            self.responses[matching[0]] = raw
        elif acked and open_:
            self.responses[open_[-1]] = raw
        else:
            self.late += 1

    def complete(self, *, acks: bool = True) -> bool:
        """The last packet has its whole reply (with acks: an ack, and the
        response an ack_pending promises)."""
        if not acks:
            return self.responses[-1] is not None
        ack = self.acks[-1]
        if ack is None:
            return False
        return ack != AckCode.ack_pending or self.responses[-1] is not None

    def observations(self) -> list[Observation]:
        return [
            Observation(ack, response, concatenated)
            for ack, response, concatenated in zip(
                self.acks, self.responses, self.concatenated, strict=True
            )
        ]
