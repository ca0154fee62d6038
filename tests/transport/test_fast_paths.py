"""The requester link's one-pass ends send the same bytes and leave the same state as the reference.

Two requester links start the same transactions and get the same ack frames:
answers as a thesis node makes them, or spoiled (a flipped bit, another ack
code, the ack alone, a label nobody holds, a sound response that answers
something else). Every frame each link sends, every event and the requester's
state must be equal after every step.
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Requester, Responder
from fw1394.engine.policy import POLICIES
from fw1394.packets import (
    AckCode,
)
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.fast import decode_packet, encode_packet
from fw1394.packets.nodeid import node_id
from fw1394.transport.link import RequesterLink, ResponderLink
from fw1394.transport.sansio.wire import FrameHeader, FrameKind

MEMORY = 256
ME = 2


# -- the requester's side ----------------------------------------------------------------
HOST = 5


def _hosts(split_timeout: float) -> tuple[list[Any], list[RequesterLink]]:
    sent: list[Any] = []
    links = []
    for path in ("fast", "reference"):

        def send(kind: int, destination: int, payload: bytes, path: str = path) -> None:
            sent.append((path, kind, destination, bytes(payload)))

        requester = Requester(
            node_id(HOST), split_timeout=split_timeout, ack_timeout=0.05, duplicate_window=0.0
        )
        link = RequesterLink(requester, send)
        if path == "reference":
            link.fast_ack = None
        links.append(link)
    return sent, links


def _answer(request: Any, mutation: int, where: int) -> bytes:
    """The ack frame payload a thesis node sends for ``request``, then spoiled by ``mutation``."""
    out: list[bytes] = []
    space = MemorySpace(MEMORY)
    responder = Responder(request.destination_id, space, POLICIES["thesis"])
    ResponderLink(responder, lambda kind, to, payload: out.append(payload)).serve(
        encode_packet(request), HOST, 1, 0.0
    )
    payload = bytearray(out[0] if out else bytes(8))
    if mutation == 1 and len(payload) > 8:  # a flipped bit in the response
        payload[8 + where % (len(payload) - 8)] ^= 1 << (where % 8)
    elif mutation == 2:  # another ack code
        payload[0] = ACK_BYTES[
            [AckCode.ack_busy_X, AckCode.ack_complete, AckCode.ack_pending][where % 3]
        ]
    elif mutation == 3:  # the ack alone
        del payload[8:]
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
def test_fast_requester_link_equals_reference(split_timeout: float, script: list[Any]) -> None:
    sent, links = _hosts(split_timeout)
    now = 1.0
    for number, step in enumerate(script):
        if step[0] == "time":
            now += step[1]
            for link in links:
                link.requester.handle_timer(now)
                link.flush()
        elif step[0] == "start":
            _, kind, phy, offset, length = step
            for link in links:
                requester, to = link.requester, node_id(phy)
                if kind == "qr":
                    requester.read_quadlet(to, offset, now)
                elif kind == "br":
                    requester.read_block(to, offset, length, now)
                elif kind == "qw":
                    requester.write_quadlet(to, offset, length * 0x01010101, now)
                else:
                    requester.write_block(to, offset, bytes(range(length)), now)
                link.flush()
        else:
            _, index, mutation, where = step
            reference = links[1].requester
            live = sorted(reference._transactions.values(), key=lambda t: t.tid)
            live = [t for t in live if t.label >= 0]
            if not live:
                continue
            transaction = live[index % len(live)]
            payload = _answer(transaction.request, mutation, where)
            header = FrameHeader(FrameKind.ack, 1, 9, 0, transaction.key, HOST, sequence=number)
            for link in links:
                link.take(header, payload, now)
        fast = [frame[1:] for frame in sent if frame[0] == "fast"]
        assert fast == [frame[1:] for frame in sent if frame[0] == "reference"], step
        sent.clear()
        events = [link.requester.events() for link in links]
        assert events[0] == events[1], step
        states = [
            (
                link.requester.in_flight(),
                link.requester.outstanding,
                link.requester.next_deadline(),
            )
            for link in links
        ]
        assert states[0] == states[1], step
