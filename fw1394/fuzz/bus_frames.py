"""Frames a broken or hostile member might put on a virtual bus.

Every receive path of a member (bus management, data, acks, PHY packets) must
survive whatever arrives: on an insecure bus anyone on the host can send, and
on a keyed bus a member with a bug can. :func:`hostile_frame` draws one frame
from a random source: a header that passes the socket filter (magic, version,
the bus's tag, a destination some member listens to) over a payload that is
short, long, truncated or random for its kind, with a generation near the
bus's or anywhere in 32 bits. ``bench/frame_storm.py`` and the transport tests
throw them at live buses.
"""

from __future__ import annotations

import random

from fw1394.packets import QuadletReadRequest, QuadletWriteRequest, encode
from fw1394.packets.nodeid import BROADCAST_PHY, node_id
from fw1394.transport.sansio.wire import (
    ACK_PAYLOAD,
    EVERY_MEMBER,
    JOIN_TARGET,
    MAX_MEMBERS,
    MEMBER,
    TABLE,
    FrameHeader,
    FrameKind,
    MemberInfo,
    pack_join,
    pack_table,
)

KINDS = tuple(FrameKind)


def _member(rng: random.Random) -> MemberInfo:
    return MemberInfo(
        member_id=rng.getrandbits(32),
        rank=rng.getrandbits(64),
        contender=rng.random() < 0.5,
        host=rng.random() < 0.5,
        board_id=rng.randrange(256),
        pid=rng.getrandbits(32),
        address=".".join(str(rng.randrange(256)) for _ in range(4)),
        pid_namespace=rng.getrandbits(16),
    )


def _shaped(kind: int, rng: random.Random) -> bytes:
    """A payload of about the right shape for ``kind`` (before any damage)."""
    if kind in (FrameKind.beacon, FrameKind.bus_reset):
        members = tuple(_member(rng) for _ in range(rng.randrange(4)))
        table = pack_table(members, rng.getrandbits(32))
        if rng.random() < 0.3:  # a count the bytes do not back
            count = rng.choice((MAX_MEMBERS, MAX_MEMBERS + 1, 0xFFFF, len(members) + 1))
            table = TABLE.pack(rng.getrandbits(32), count, 0) + table[TABLE.size :]
        return table
    if kind == FrameKind.join:
        return pack_join(_member(rng), rng.choice((0, rng.getrandbits(32))))
    if kind == FrameKind.refused:
        return JOIN_TARGET.pack(rng.getrandbits(32)) + rng.randbytes(rng.randrange(40))
    if kind == FrameKind.ack:
        ack = ACK_PAYLOAD.pack(rng.randrange(256), rng.randrange(256), 0, rng.getrandbits(32))
        return ack + rng.randbytes(rng.choice((0, 0, 4, 16, 20, 24)))
    if kind == FrameKind.async_packet:
        destination = node_id(rng.choice((0, 1, 2, BROADCAST_PHY, rng.randrange(64))))
        packet = (
            QuadletReadRequest(
                destination_id=destination,
                tlabel=rng.randrange(64),
                source_id=node_id(rng.randrange(64)),
                offset=rng.getrandbits(48),
            )
            if rng.random() < 0.5
            else QuadletWriteRequest(
                destination_id=destination,
                tlabel=rng.randrange(64),
                source_id=node_id(rng.randrange(64)),
                offset=rng.getrandbits(48),
                quadlet_data=rng.getrandbits(32),
            )
        )
        return encode(packet)
    return rng.randbytes(rng.choice((0, 4, 8, 12, MEMBER.size)))


def _damaged(payload: bytes, rng: random.Random) -> bytes:
    choice = rng.random()
    if choice < 0.3 or not payload:
        return payload
    if choice < 0.6:
        return payload[: rng.randrange(len(payload))]  # cut short
    blob = bytearray(payload)
    if choice < 0.85:
        for _ in range(rng.randint(1, 4)):
            blob[rng.randrange(len(blob))] = rng.randrange(256)
        return bytes(blob)
    return bytes(blob) + rng.randbytes(rng.randint(1, 64))


def hostile_frame(rng: random.Random, tag: int, generation: int) -> bytes:
    """One frame for the bus with tag ``tag``, now in ``generation``."""
    roll = rng.random()
    kind = rng.choice(KINDS) if roll < 0.9 else rng.randrange(256)
    near = max(0, generation + rng.randint(-2, 2))
    header = FrameHeader(
        kind=int(kind),
        tag=tag if rng.random() < 0.97 else rng.getrandbits(32),
        sender=rng.getrandbits(32),
        generation=near if rng.random() < 0.8 else rng.getrandbits(32),
        sender_phy=rng.choice((rng.randrange(64), 0xFF, rng.randrange(256))),
        destination=rng.choice((0, 1, 2, BROADCAST_PHY, EVERY_MEMBER, rng.randrange(256))),
        speed=rng.randrange(256),
        sequence=rng.getrandbits(32),
    )
    if rng.random() < 0.05:
        return header.pack()[: rng.randrange(24)]  # not even a whole header
    payload = _damaged(_shaped(int(kind), rng), rng)
    return header.pack() + payload
