"""A management frame that is not well formed changes nothing and is a counted drop.

Payloads are built here from the table in docs/virtual-bus.md ("Kinds and
payloads", "Member table"): an 8-byte table head (initiator, count, reserved),
24-byte member entries, a join as an entry plus the 4-byte member ID of the
coordinator asked, a refusal as a 4-byte member ID plus a reason.
"""

from __future__ import annotations

import copy
import struct

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.transport.sansio.membership import MAX_GENERATION, Membership, Role, Timing
from fw1394.transport.sansio.wire import FrameError, FrameHeader, FrameKind, MemberInfo

ENTRY = 24
TABLE_HEAD = 8
ME = MemberInfo(member_id=0x1111, rank=5)


def entry(member_id: int, rank: int) -> bytes:
    return struct.pack(">IQBBHI4s", member_id, rank, 0, 0xFF, 0, 1234, bytes([127, 0, 0, 1]))


def coordinating() -> Membership:
    """A member that founded a bus of its own (the coordinator, physical ID 0)."""
    membership = Membership(ME, 0.0, Timing())
    membership.tick(2.0)  # no beacon within a lease: it founds the bus
    assert membership.role is Role.coordinator
    membership.outgoing()
    membership.changes()
    return membership


def state(membership: Membership) -> tuple[object, ...]:
    boss = membership._boss
    return (
        membership.role,
        membership.generation,
        membership.members,
        membership.phy_id,
        membership._highest_generation,
        dict(boss.last_heard),
        dict(boss.joins),
        boss.reset_due,
    )


def header(kind: FrameKind, generation: int = 1, sender: int = 0x2222) -> FrameHeader:
    return FrameHeader(kind, 0, sender, generation, 0xFF, 0xFF)


SHORT = [
    (FrameKind.beacon, b""),
    (FrameKind.beacon, struct.pack(">IHH", 0, 1, 0)),  # one entry promised, none there
    (FrameKind.bus_reset, struct.pack(">IHH", 0, 2, 0) + entry(0x2222, 1)),
    (FrameKind.bus_reset, struct.pack(">IHH", 0, 64, 0) + entry(0x2222, 1) * 64),  # > 63
    (FrameKind.join, entry(0x2222, 1)),  # no coordinator ID
    (FrameKind.join, entry(0x2222, 1)[:10]),
    (FrameKind.refused, b"\x00\x00"),
]


@pytest.mark.parametrize(("kind", "payload"), SHORT, ids=[f"{k.name}-{len(p)}" for k, p in SHORT])
def test_a_short_or_lying_payload_raises_frame_error_and_changes_nothing(
    kind: FrameKind, payload: bytes
) -> None:
    membership = coordinating()
    before = state(membership)
    with pytest.raises(FrameError):
        membership.receive(header(kind, generation=9), payload, 2.1)
    assert state(membership) == before
    assert membership.outgoing() == [] and membership.changes() == []


def test_a_generation_no_bus_reaches_is_refused() -> None:
    membership = coordinating()
    before = state(membership)
    join = entry(0x2222, 1) + struct.pack(">I", 0)
    with pytest.raises(FrameError):
        membership.receive(header(FrameKind.join, generation=MAX_GENERATION + 1), join, 2.1)
    assert state(membership) == before
    # The same join in a plausible generation is taken: a reset is scheduled.
    membership.receive(header(FrameKind.join, generation=1), join, 2.1)
    assert membership._boss.reset_due is not None


def test_frames_from_strangers_do_not_grow_the_coordinators_lease_table() -> None:
    membership = coordinating()
    for sender in range(1, 1000):
        membership.receive(header(FrameKind.heartbeat, sender=sender), b"", 2.1)
    assert set(membership._boss.last_heard) == {ME.member_id}


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from([k for k in FrameKind if k >= FrameKind.join]),
    st.binary(max_size=3 * ENTRY + TABLE_HEAD + 8),
    st.integers(0, 2**32 - 1),
)
def test_any_payload_either_parses_or_changes_nothing(
    kind: FrameKind, payload: bytes, generation: int
) -> None:
    membership = coordinating()
    before = state(membership)
    probe = copy.deepcopy(membership)
    try:
        probe.receive(header(kind, generation=generation), payload, 2.1)
    except FrameError:
        assert state(probe) == before
        assert probe.outgoing() == [] and probe.changes() == []
