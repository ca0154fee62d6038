"""The adapter protocol's struct fast path equals its construct descriptions.

Every libraw1394 call becomes a :data:`REQUEST` and a :data:`REPLY`; the
adapter packs and parses them with struct formats for speed. Here the
declarative descriptions (``REQUEST``/``REPLY``, what ``docs/host-adapter.md``
documents) build and parse the same messages for any field values: bytes equal
both ways, and damaged messages are refused by both.
"""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st

from fw1394.transport.host_adapter.protocol import (
    LENGTH,
    REPLY,
    REQUEST,
    Op,
    ProtocolError,
    Reply,
    Request,
    Status,
    ok_reply,
    one_transfer,
    parse_reply,
    parse_request,
)

u8, u16, u32 = (st.integers(0, (1 << bits) - 1) for bits in (8, 16, 32))
signed8 = st.integers(-128, 127)
# Float32b round-trips only values a 32-bit float holds.
float32 = st.floats(width=32, allow_nan=False)
blobs = st.binary(max_size=300)
texts = st.text(max_size=60)

requests = st.builds(
    Request,
    request=u32,
    op=st.sampled_from(Op),
    node=u8,
    offset=st.integers(0, (1 << 64) - 1),
    length=u32,
    quadlet=st.booleans(),
    extended_tcode=u16,
    wait=float32,
    argument=blobs,
    data=blobs,
    generation=st.integers(0, (1 << 40)),
)
replies = st.builds(
    Reply,
    request=u32,
    status=st.sampled_from(Status),
    generation=st.integers(0, (1 << 40)),
    phy=u8,
    ack=signed8,
    rcode=signed8,
    outcome_unknown=st.booleans(),
    reason=st.text(max_size=20).filter(lambda t: len(t.encode()) < 256),
    detail=texts,
    data=blobs,
)


def body(frame: bytes) -> bytes:
    (size,) = LENGTH.unpack_from(frame)
    assert size == len(frame) - LENGTH.size
    return frame[LENGTH.size :]


@given(requests)
def test_request_bytes_equal_the_description(request: Request) -> None:
    described = REQUEST.build(
        {
            "request": request.request,
            "op": int(request.op),
            "node": request.node,
            "extended_tcode": request.extended_tcode,
            "generation": request.generation & 0xFFFFFFFF,
            "offset": request.offset,
            "length": request.length,
            "quadlet": int(request.quadlet),
            "wait": request.wait,
            "argument": request.argument,
            "data": request.data,
        }
    )
    assert body(request.pack()) == described
    parsed = REQUEST.parse(described)
    again = parse_request(described)
    assert again.generation == parsed.generation == request.generation & 0xFFFFFFFF
    assert (again.op, again.offset, again.wait, again.argument, again.data) == (
        parsed.op,
        parsed.offset,
        parsed.wait,
        parsed.argument,
        parsed.data,
    )
    assert again == Request(**{**_fields(request), "generation": parsed.generation})


@given(replies)
def test_reply_bytes_equal_the_description(reply: Reply) -> None:
    described = REPLY.build(
        {
            "request": reply.request,
            "status": int(reply.status),
            "generation": reply.generation & 0xFFFFFFFF,
            "phy": reply.phy,
            "ack": reply.ack,
            "rcode": reply.rcode,
            "outcome_unknown": int(reply.outcome_unknown),
            "reason": reply.reason,
            "detail": reply.detail,
            "data": reply.data,
        }
    )
    assert body(reply.pack()) == described
    parsed = REPLY.parse(described)
    again = parse_reply(described)
    assert (again.reason, again.detail, again.data, again.ack, again.rcode) == (
        parsed.reason,
        parsed.detail,
        parsed.data,
        parsed.ack,
        parsed.rcode,
    )
    assert again == Reply(**{**_fields(reply), "generation": parsed.generation})


@given(requests, st.data())
def test_a_cut_request_is_refused_by_both(request: Request, data: st.DataObject) -> None:
    whole = body(request.pack())
    cut = whole[: data.draw(st.integers(0, len(whole) - 1))]
    with pytest.raises(Exception):  # noqa: B017 - construct raises many kinds
        REQUEST.parse(cut)
    with pytest.raises(ProtocolError):
        parse_request(cut)


@given(replies, st.data())
def test_a_cut_reply_is_refused_by_both(reply: Reply, data: st.DataObject) -> None:
    whole = body(reply.pack())
    cut = whole[: data.draw(st.integers(0, len(whole) - 1))]
    with pytest.raises(Exception):  # noqa: B017 - construct raises many kinds
        REPLY.parse(cut)
    with pytest.raises(ProtocolError):
        parse_reply(cut)


@given(u32, st.integers(0, (1 << 40)), u8, blobs)
def test_an_ok_reply_in_one_step_equals_the_description(
    number: int, generation: int, phy: int, data: bytes
) -> None:
    described = REPLY.build(
        {
            "request": number,
            "status": 0,
            "generation": generation & 0xFFFFFFFF,
            "phy": phy,
            "ack": -1,
            "rcode": -1,
            "outcome_unknown": 0,
            "reason": "",
            "detail": "",
            "data": data,
        }
    )
    assert ok_reply(number, generation, phy, data) == LENGTH.pack(len(described)) + described


# Reads and writes, the express path's, half of them with no lock argument.
transfers = st.builds(
    Request,
    request=u32,
    op=st.sampled_from([Op.read, Op.write, Op.lock, Op.send]),
    node=u8,
    offset=st.integers(0, (1 << 64) - 1),
    length=u32,
    quadlet=st.booleans(),
    generation=u32,
    argument=st.one_of(st.just(b""), blobs),
    data=blobs,
)


@given(st.one_of(requests, transfers), st.binary(max_size=3))
def test_one_transfer_reads_a_lone_read_or_write_as_the_description(
    request: Request, extra: bytes
) -> None:
    frame = request.pack()
    parsed = REQUEST.parse(body(frame))
    found = one_transfer(frame)
    if parsed.op not in (Op.read, Op.write) or parsed.argument:
        assert found is None
    else:
        assert found == (
            parsed.request,
            parsed.op,
            parsed.node,
            parsed.generation,
            parsed.offset,
            parsed.length,
            parsed.quadlet,
            parsed.data,
        )
    # Anything but exactly one whole message goes the general way.
    assert one_transfer(frame[:-1]) is None
    assert one_transfer(LENGTH.pack(len(frame) - LENGTH.size + 1) + frame[LENGTH.size :]) is None
    # A data length that is not what the message holds (the general way refuses it).
    at = len(frame) - len(request.data) - 4
    (size,) = LENGTH.unpack_from(frame, at)
    wrong = frame[:at] + LENGTH.pack(size + 1) + frame[at + 4 :]
    assert one_transfer(wrong) is None
    with pytest.raises(ProtocolError):
        parse_request(body(wrong))
    if extra:
        assert one_transfer(frame + extra) is None


def test_a_write_with_a_lock_argument_goes_the_general_way() -> None:
    # Its 4-byte argument reads like an empty write's data length: only the
    # argument's own length tells them apart.
    frame = Request(1, Op.write, argument=LENGTH.pack(4)).pack()
    assert one_transfer(frame) is None
    assert one_transfer(Request(1, Op.write).pack()) is not None


def test_unknown_operation_and_status_are_refused() -> None:
    request = body(Request(1, Op.read).pack())
    with pytest.raises(ProtocolError):
        parse_request(request[:4] + bytes([200]) + request[5:])
    reply = body(Reply(1, Status.ok).pack())
    with pytest.raises(ProtocolError):
        parse_reply(reply[:4] + bytes([9]) + reply[5:])


def _fields(message: Request | Reply) -> dict[str, object]:
    return {name: getattr(message, name) for name in message.__slots__}
