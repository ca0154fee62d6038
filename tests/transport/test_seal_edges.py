"""The verifier's memory of senders: bounded, the oldest forgotten first.

Frames and trailers are built here from the layout of ``tests/vectors/bus_frames.json``
(24-byte header; trailer = u64 counter + BLAKE2s-128 keyed with the bus key over
frame and counter) with ``struct`` and ``hashlib`` alone, not with fw1394's sealer.
"""

from __future__ import annotations

import hashlib
import struct

from fw1394.transport.sansio.seal import MAX_SENDERS, Verifier

KEY = bytes(range(32))


def sealed(sender: int, counter: int = 1) -> bytes:
    # magic, version, kind 1 (async packet), bus tag, sender, generation 5, sender phy 1,
    # destination phy 0, speed 2, reserved, sequence 7; a 4-byte payload.
    frame = struct.pack(">HBBIIIBBBBI", 0x4657, 1, 1, 0x1394ABCD, sender, 5, 1, 0, 2, 0, 7)
    body = frame + b"\xff\xc0\x0c\x40" + struct.pack(">Q", counter)
    return body + hashlib.blake2s(body, key=KEY, digest_size=16).digest()


def test_the_oldest_sender_is_forgotten_only_when_one_more_than_the_limit_arrives() -> None:
    verifier = Verifier(KEY)
    first = sealed(sender=1)
    assert verifier.open(first) is not None
    for sender in range(2, MAX_SENDERS + 1):
        assert verifier.open(sealed(sender)) is not None
    # Exactly MAX_SENDERS senders known: the first one's frame is still a replay.
    assert verifier.open(first) is None
    assert verifier.dropped.replayed == 1
    # One more sender: the oldest entry goes, and with it the memory of that frame.
    assert verifier.open(sealed(sender=MAX_SENDERS + 1)) is not None
    assert verifier.open(first) is not None
    # Taking the first sender in again pushed out the next oldest (2); 3 is remembered.
    assert verifier.open(sealed(sender=3)) is None
    assert verifier.open(sealed(sender=2)) is not None
