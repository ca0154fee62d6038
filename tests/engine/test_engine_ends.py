"""The requester's ends on flat bytes against the table's way.

``concatenated_data`` must accept only ack frames whose response the table's
way (:meth:`Requester.receive_ack`, then :meth:`Requester.receive_response`)
completes a read with, every such frame whose response is sound, and return
that read's data. :meth:`Requester.take_ack_frame`, whose common case ends a
transaction on the frame's bytes, must leave two requesters that start the same
transactions in the same state, with the same events, as the table's way does,
for answers as a thesis node makes them and spoiled ones (a flipped bit, another
ack code, the ack alone, a label nobody holds, a sound response that answers
something else). A requester driven through :meth:`Requester.begin` (then
``finish`` or ``adopt``) must be in the same state after every transaction as
one driven the table's way only.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import ReadCompleted, Requester, Responder
from fw1394.engine.policy import POLICIES
from fw1394.engine.requester import concatenated_data
from fw1394.packets import (
    AckCode,
    BlockReadResponse,
    PacketError,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    RCode,
)
from fw1394.packets.ack import ACK_BYTES, ack_code
from fw1394.packets.fast import decode_packet, decode_sound, encode_packet
from fw1394.packets.frame import ACK_FRAME_FORMAT
from fw1394.packets.nodeid import node_id, phy_of

ME, NODE = node_id(5), node_id(2)
MEMORY = 256
NOW = 10.0


SPOILS = ["label", "source", "destination", "rcode", "size", "class", "ack", "ack label", "sender"]


@st.composite
def answers(draw: Any) -> tuple[int, int | None, bytes, int]:
    """(the read's destination, its block length (None: a quadlet read), an ack frame
    payload answering it, the ack's sender).

    The answer is right, or has one thing wrong (``SPOILS``), or a flipped bit.
    """
    block = draw(st.booleans())
    length = draw(st.integers(0, 12)) if block else -1
    spoil = draw(st.sampled_from(["", "", "", "flip", *SPOILS]))
    target = draw(st.sampled_from([NODE, node_id(2, 7)]))  # a node of this bus or another

    def pick(name: str, right: list[int], wrong: list[int]) -> int:
        return int(draw(st.sampled_from(wrong if spoil == name else right)))

    route: dict[str, Any] = {
        "tlabel": pick("label", [0], [1, 63]),  # the request's label is 0
        # The local bus by its number 0x3FF or by another: the same node.
        "source_id": pick("source", [target, NODE], [node_id(3), node_id(2, 8)]),
        "destination_id": pick("destination", [ME, ME & 0x3F], [node_id(5, 9), node_id(6)]),
        "rcode": pick("rcode", [RCode.resp_complete], [RCode.resp_address_error]),
    }
    if (spoil == "class") != block:
        size = max(length, 0) + pick("size", [0], [-1, 1, 4]) if length > 0 else 0
        data = draw(st.binary(min_size=size, max_size=size))
        response: Any = BlockReadResponse(**route, data=data)
    else:
        response = QuadletReadResponse(**route, quadlet_data=draw(st.integers(0, 2**32 - 1)))
    wire = bytearray(encode_packet(response))
    if spoil == "flip":
        wire[draw(st.integers(0, len(wire) - 1))] ^= 1 << draw(st.integers(0, 7))
    ack = pick("ack", [AckCode.ack_pending], [AckCode.ack_complete, AckCode.ack_busy_X])
    payload = ACK_FRAME_FORMAT.pack(ACK_BYTES[ack], pick("ack label", [0], [3]), 0, 1)
    return target, length if block else None, payload + bytes(wire), pick("sender", [2], [3])


@settings(max_examples=500)
@given(answers())
def test_concatenated_data_is_what_the_general_path_completes_a_read_with(
    answer: tuple[int, int | None, bytes, int],
) -> None:
    target, length, payload, sender = answer
    requester = Requester(ME, duplicate_window=0.0)
    if length is None:
        requester.read_quadlet(target, 0, NOW)
    else:
        requester.read_block(target, 0, length, NOW)
    response_class = QuadletReadResponse if length is None else BlockReadResponse
    expected = -1 if length is None else length
    data = concatenated_data(payload, sender, response_class, target, expected, ME)
    # The general path: the ack, then the response behind it, as the link hands them over.
    requester.receive_ack(node_id(sender), payload[1], ack_code(payload[0]), NOW)
    try:
        packet = decode_packet(payload[8:])
    except PacketError:
        pass
    else:
        requester.receive_response(packet, NOW)
    completed = [e.data for e in requester.events() if isinstance(e, ReadCompleted)]
    if data is not None:
        assert completed == [data]
    elif decode_sound(payload[8:]) is not None:
        # Only a damaged response may be declined and still complete the general
        # way (the requester does not look at CRCs; the link hands it over).
        assert completed == []


def _state(requester: Requester) -> tuple[Any, ...]:
    labels = requester._labels
    transactions = [
        (t.tid, t.key, t.label, t.state, t.deadline, t.queued, t.busy, t.request, t.length)
        for t in requester._transactions.values()
    ]
    by_label = {key: t.tid for key, t in requester._by_label.items()}
    return (
        requester._next_tid,
        labels._held,
        labels._next,
        labels._until,
        requester._ended,
        requester._timers,
        transactions,
        by_label,
        requester._outbox,
        requester._events,
    )


#: (kind, destination phy, how it ends, seconds before it starts)
transactions = st.tuples(
    st.sampled_from(["read", "write"]),
    st.sampled_from([2, 3]),
    st.sampled_from(["clean", "clean", "busy", "error", "timeout"]),
    st.sampled_from([0.0, 0.001, 0.5]),
)


@settings(max_examples=200)
@given(st.sampled_from([0.0, 0.05]), st.lists(transactions, max_size=20))
def test_begin_leaves_the_requester_as_the_tables_way_does(
    window: float, script: list[tuple[str, int, str, float]]
) -> None:
    general = Requester(ME, split_timeout=0.1, duplicate_window=window)
    solo_requester = Requester(ME, split_timeout=0.1, duplicate_window=window)
    solo = solo_requester
    now = NOW
    for kind, phy, end, pause in script:
        now += pause
        for requester in (general, solo_requester):
            requester.handle_timer(now)
        destination = node_id(phy)
        if kind == "read":
            tid = general.read_quadlet(destination, 64, now)
        else:
            tid = general.write_quadlet(destination, 64, 7, now)
        (request,) = general.packets_to_send()
        label = solo.begin(destination, now)
        assert label == request.tlabel  # type: ignore[attr-defined]
        if end == "clean":
            if kind == "read":
                response = QuadletReadResponse(
                    destination_id=ME, tlabel=label, source_id=destination, quadlet_data=9
                )
                general.receive_ack(destination, label, AckCode.ack_pending, now)
                general.receive_response(response, now)
            else:
                general.receive_ack(destination, label, AckCode.ack_complete, now)
            general.events()
            solo.finish(now)
        else:
            # Adopted as it was sent, the transaction ends the general way on both.
            make = QuadletReadRequest if kind == "read" else QuadletWriteRequest
            values: dict[str, Any] = {} if kind == "read" else {"quadlet_data": 7}
            adopted = make(
                destination_id=destination, tlabel=label, source_id=ME, offset=64, **values
            )
            assert solo.adopt(adopted, -1, kind == "read") == tid
            assert _state(solo_requester) == _state(general)
            for requester in (general, solo_requester):
                if end == "busy":
                    requester.receive_ack(destination, label, AckCode.ack_busy_X, now)
                elif end == "error":
                    requester.receive_ack(destination, label, AckCode.ack_address_error, now)
                ended = now
                while (due := requester.next_deadline()) is not None and requester.outstanding:
                    ended = due  # retries get no ack: they time out
                    requester.handle_timer(due)
                    requester.packets_to_send()
                requester.events()
            now = ended
        assert _state(solo_requester) == _state(general)


def test_begin_leaves_what_it_cannot_do_alone_to_the_usual_start() -> None:
    requester = Requester(ME)
    solo = requester
    assert solo.begin(node_id(63), NOW) == -1  # a broadcast
    requester.read_quadlet(NODE, 0, NOW)
    assert solo.begin(node_id(3), NOW) == -1  # something else is outstanding
    assert requester._next_tid == 2
    held = Requester(ME, duplicate_window=10.0)
    solo = held
    for _ in range(64):
        assert solo.begin(NODE, NOW) >= 0
        solo.finish(NOW)
    assert solo.begin(NODE, NOW) == -1  # every label to the node is held
    assert held._next_tid == 65
    assert solo.begin(NODE, NOW + 10.0) >= 0


# -- the requester's side ----------------------------------------------------------------
HOST = 5


def _hosts(split_timeout: float) -> list[Requester]:
    return [
        Requester(
            node_id(HOST), split_timeout=split_timeout, ack_timeout=0.05, duplicate_window=0.0
        )
        for _ in ("bytes", "table")
    ]


def _by_the_table(requester: Requester, sender: int, payload: bytes, now: float) -> int:
    """An ack frame taken the table's way: the ack, then a sound response behind it
    (a link drops a damaged one unacked); the label of a response to ack, or -1."""
    requester.receive_ack(node_id(sender), payload[1], ack_code(payload[0]), now)
    if len(payload) > 8:
        packet = decode_sound(payload[8:])
        if packet is not None and requester.receive_response(packet, now) is not None:
            return int(packet.tlabel)  # type: ignore[attr-defined]
    return -1


def _answer(request: Any, mutation: int, where: int) -> bytes:
    """The ack frame payload a thesis node sends for ``request``, then spoiled by ``mutation``."""
    space = MemorySpace(MEMORY)
    responder = Responder(request.destination_id, space, POLICIES["thesis"])
    answer = responder.serve(encode_packet(request), 1, 0.0)
    payload = bytearray(answer if isinstance(answer, bytes) else bytes(8))
    if mutation == 1 and len(payload) > 8:  # a flipped bit in the response
        payload[8 + where % (len(payload) - 8)] ^= 1 << (where % 8)
    elif mutation == 2:  # another ack code
        payload[0] = ACK_BYTES[
            [AckCode.ack_busy_X, AckCode.ack_complete, AckCode.ack_pending][where % 3]
        ]
    elif mutation == 3:  # the ack alone, maybe ack_complete (a read needs its response)
        del payload[8:]
        if where % 2:
            payload[0] = ACK_BYTES[AckCode.ack_complete]
    elif mutation == 4:  # a label no transaction holds
        payload[1] ^= 1 + where % 63
    elif mutation >= 5 and len(payload) > 8:  # a sound response that answers something else
        response: Any = decode_packet(bytes(payload[8:]))
        if mutation == 5:
            response = replace(response, tlabel=(response.tlabel + 1 + where) % 64)
        elif mutation == 6 and hasattr(response, "data"):
            response = replace(response, data=response.data[: where % 8], data_length=-1)
        elif mutation == 7:
            response = replace(response, source_id=response.source_id ^ (1 << (where % 16)))
        else:
            response = replace(response, destination_id=node_id(where % 64, where % 1024))
        fresh = {"data_crc": None} if hasattr(response, "data") else {}
        payload[8:] = encode_packet(replace(response, header_crc=None, **fresh))
    return bytes(payload)


host_steps = st.one_of(
    st.tuples(
        st.just("start"),
        st.sampled_from(["qr", "br", "qw", "bw"]),
        st.sampled_from([0, 1]),
        st.integers(0, MEMORY // 4).map(lambda q: 4 * q),
        st.integers(0, 24),
    ),
    st.tuples(st.just("answer"), st.integers(0, 7), st.integers(0, 8), st.integers(0, 1000)),
    st.tuples(st.just("time"), st.sampled_from([0.001, 0.03, 0.2])),
)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([0.02, 0.5]), st.lists(host_steps, max_size=30))
def test_ack_frames_end_transactions_as_the_table_says(
    split_timeout: float, script: list[Any]
) -> None:
    requesters = _hosts(split_timeout)
    #: (destination phy, label) -> the request last sent with them.
    requests: dict[tuple[int, int], Any] = {}
    now = 1.0
    for step in script:
        if step[0] == "time":
            now += step[1]
            for requester in requesters:
                requester.handle_timer(now)
        elif step[0] == "start":
            _, kind, phy, offset, length = step
            for requester in requesters:
                to = node_id(phy)
                if kind == "qr":
                    requester.read_quadlet(to, offset, now)
                elif kind == "br":
                    requester.read_block(to, offset, length, now)
                elif kind == "qw":
                    requester.write_quadlet(to, offset, length * 0x01010101, now)
                else:
                    requester.write_block(to, offset, bytes(range(length)), now)
        else:
            _, index, mutation, where = step
            live = sorted(requesters[1].in_flight().items())
            if not live:
                continue
            destination, label = live[index % len(live)][1]
            request = requests[phy_of(destination), label]
            payload = _answer(request, mutation, where)
            sender = phy_of(destination)
            labels = (
                requesters[0].take_ack_frame(sender, payload, now),
                _by_the_table(requesters[1], sender, payload, now),
            )
            assert labels[0] == labels[1], step
        sent = [requester.packets_to_send() for requester in requesters]
        assert sent[0] == sent[1], step
        for request in sent[1]:
            requests[phy_of(request.destination_id), request.tlabel] = request  # type: ignore[attr-defined]
        events = [requester.events() for requester in requesters]
        assert events[0] == events[1], step
        states = [
            (requester.in_flight(), requester.outstanding, requester.next_deadline())
            for requester in requesters
        ]
        assert states[0] == states[1], step


def test_a_write_acked_complete_with_a_response_behind_it_ends_both_as_the_table_says() -> None:
    # A write's ack_complete with a sound response behind it (for a read of the same
    # node still waiting for its ack): the one-pass end of a bare ack must not
    # swallow the response, which the table's way takes.
    requesters = _hosts(0.5)
    node = node_id(2)
    for requester in requesters:
        requester.write_quadlet(node, 0, 7, NOW)
        requester.read_quadlet(node, 4, NOW)
    sent = [requester.packets_to_send() for requester in requesters]
    write, read = sent[1]
    assert isinstance(write, QuadletWriteRequest) and isinstance(read, QuadletReadRequest)
    response = QuadletReadResponse(
        destination_id=node_id(HOST), tlabel=read.tlabel, source_id=node, quadlet_data=9
    )
    ack = ACK_FRAME_FORMAT.pack(ACK_BYTES[AckCode.ack_complete], write.tlabel, 0, 1)
    payload = ack + encode_packet(response)
    labels = (
        requesters[0].take_ack_frame(2, payload, NOW),
        _by_the_table(requesters[1], 2, payload, NOW),
    )
    assert labels[0] == labels[1]
    events = [requester.events() for requester in requesters]
    assert events[0] == events[1]
    # The table ends the write and sees the response (early: its read has no ack yet).
    assert [type(event).__name__ for event in events[1]] == ["WriteCompleted", "UnexpectedResponse"]
