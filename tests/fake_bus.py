"""A bus of membership state machines joined by a fake medium: no sockets, no clock."""

from __future__ import annotations

from fw1394.packets.nodeid import BROADCAST_PHY
from fw1394.transport.sansio.membership import Membership, Timing
from fw1394.transport.sansio.wire import EVERY_MEMBER, FrameHeader, MemberInfo

# Fast enough that a test runs seconds of bus time in a few thousand steps.
FAKE_TIMING = Timing(heartbeat=0.1, lease=0.5, join_retry=0.05, settle=0.002, self_id_timeout=0.5)
TAG = 0x1234


class FakeBus:
    """Every frame reaches every other live member; time moves in steps."""

    def __init__(self, timing: Timing = FAKE_TIMING) -> None:
        self.timing = timing
        self.now = 0.0
        self.members: dict[int, Membership] = {}
        self.dead: set[int] = set()

    def add(self, rank: int, contender: bool = False, member_id: int | None = None) -> Membership:
        member_id = member_id or 1000 + len(self.members)
        info = MemberInfo(member_id, rank, contender=contender, host=contender)
        membership = Membership(info, self.now, self.timing)
        self.members[info.member_id] = membership
        return membership

    def kill(self, membership: Membership) -> None:
        self.dead.add(membership.me.member_id)

    def run(self, seconds: float, step: float = 0.01) -> None:
        end = self.now + seconds
        while self.now < end:
            self.now += step
            for member_id, membership in list(self.members.items()):
                if member_id not in self.dead:
                    membership.tick(self.now)
            self.deliver()

    def deliver(self) -> None:
        moved = True
        while moved:
            moved = False
            for member_id, sender in list(self.members.items()):
                if member_id in self.dead:
                    sender.outgoing()
                    continue
                for out in sender.outgoing():
                    moved = True
                    phy = 0xFF if sender.phy_id is None else sender.phy_id
                    header = FrameHeader(
                        out.kind, TAG, member_id, sender.generation, phy, out.destination
                    )
                    for other_id, other in self.members.items():
                        if other_id == member_id or other_id in self.dead:
                            continue
                        wanted = out.destination in (EVERY_MEMBER, BROADCAST_PHY, other.phy_id)
                        if wanted:
                            other.receive(header, out.payload, self.now)

    def live(self) -> list[Membership]:
        return [m for i, m in self.members.items() if i not in self.dead]


def settled(bus: FakeBus) -> tuple[int, tuple[MemberInfo, ...]]:
    live = bus.live()
    generations = {m.generation for m in live}
    tables = {m.members for m in live}
    assert len(generations) == 1 and len(tables) == 1, (generations, len(tables))
    assert all(m.ready for m in live)
    return generations.pop(), tables.pop()
