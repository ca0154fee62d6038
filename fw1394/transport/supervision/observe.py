"""Looking at a bus from outside: its coordinator's beacons, and asking for a reset.

Used by ``fw1394 bus status`` and ``fw1394 bus reset``: neither joins the bus,
so looking does not itself cause a bus reset.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass

from fw1394.packets.frame import FRAME_TRAILER_SIZE
from fw1394.transport.media.choice import open_medium
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.seal import Sealer, Verifier
from fw1394.transport.sansio.wire import (
    EVERY_MEMBER,
    HEADER_SIZE,
    MEMBER,
    NO_PHY,
    TABLE,
    FrameError,
    FrameHeader,
    FrameKind,
    MemberInfo,
    parse_header,
    parse_table,
)
from fw1394.transport.supervision.bus_key import key_for

#: How long a keyless observer that heard a beacon without a MAC listens on for
#: one with a MAC (three of the default heartbeats).
SEALED_GRACE = 0.3


@dataclass(frozen=True, slots=True)
class BusView:
    """The member table a coordinator beaconed, in physical-ID order.

    ``sealed``: the beacon carried a bus key's MAC this process could not check
    (no key here); its members are then left out, as anyone could have sent it.
    """

    generation: int
    members: tuple[MemberInfo, ...]
    sealed: bool = False


def watch(
    config: BusConfig,
    timeout: float,
    accept: Callable[[BusView], bool] = lambda view: True,
) -> BusView | None:
    """The first beacon within ``timeout`` seconds whose view ``accept`` likes.

    With a key here only beacons with a valid MAC count. Without one, a beacon
    that carries a MAC says the bus is keyed (:attr:`BusView.sealed`) and
    nothing about its members.
    """
    key = key_for(config)
    verifier = None if key is None else Verifier(key)
    medium = open_medium(config, poll_interval=0.02)
    try:
        medium.filter_as_tap()
        limit = time.monotonic() + timeout
        unsealed: BusView | None = None
        while time.monotonic() < limit:
            raw = medium.receive()
            if raw is not None and verifier is not None:
                raw = verifier.open(raw)
            view = None if raw is None else _beaconed(raw, keyless=verifier is None)
            if view is None or not accept(view):
                continue
            if verifier is not None or view.sealed:
                return view
            # Without a key anyone can send a beacon without a MAC, on a keyed bus
            # too: a sealed one heard soon after says what the bus really is.
            if unsealed is None:
                unsealed = view
                limit = min(limit, time.monotonic() + SEALED_GRACE)
        return unsealed
    finally:
        medium.close()


def _beaconed(raw: bytes, keyless: bool) -> BusView | None:
    """The view in a beacon frame (its MAC already checked and cut off if there is a
    key here), or None for any other frame."""
    try:
        header = parse_header(raw)
        if header.kind != FrameKind.beacon:
            return None
        payload = raw[HEADER_SIZE:]
        _, members = parse_table(payload)
    except FrameError:
        return None
    table_size = TABLE.size + len(members) * MEMBER.size
    if keyless and len(payload) == table_size + FRAME_TRAILER_SIZE:
        # A keyed bus's beacon, seen without its key: the bus is keyed, but whether
        # a member sent this table, or anyone, cannot be told here.
        return BusView(header.generation, (), sealed=True)
    return BusView(header.generation, members)


def request_reset(config: BusConfig, generation: int) -> None:
    """Ask whoever coordinates the bus in ``generation`` for a bus reset.

    Sealed with the bus key if there is one: without it the coordinator drops
    the request (and counts it).
    """
    key = key_for(config)
    medium = open_medium(config)
    try:
        header = FrameHeader(
            FrameKind.reset_request,
            config.tag,
            secrets.randbits(32) or 1,
            generation,
            NO_PHY,
            EVERY_MEMBER,
        )
        frame = header.pack()
        medium.send(frame if key is None else Sealer(key).seal(frame))
    finally:
        medium.close()
