"""Looking at a bus from outside: its coordinator's beacons, and asking for a reset.

Used by ``fw1394 bus status`` and ``fw1394 bus reset``: neither joins the bus,
so looking does not itself cause a bus reset.
"""

from __future__ import annotations

import secrets
import time
from collections.abc import Callable
from dataclasses import dataclass

from fw1394.transport.config import BusConfig
from fw1394.transport.media import open_medium
from fw1394.transport.seal import Sealer, Verifier, key_for
from fw1394.transport.wire import (
    EVERY_MEMBER,
    HEADER_SIZE,
    NO_PHY,
    FrameError,
    FrameHeader,
    FrameKind,
    MemberInfo,
    parse_header,
    parse_table,
)


@dataclass(frozen=True, slots=True)
class BusView:
    """The member table a coordinator beaconed, in physical-ID order."""

    generation: int
    members: tuple[MemberInfo, ...]


def watch(
    config: BusConfig,
    timeout: float,
    accept: Callable[[BusView], bool] = lambda view: True,
) -> BusView | None:
    """The first beacon within ``timeout`` seconds whose view ``accept`` likes.

    On a keyed bus only beacons with a valid MAC count (without the key, none do).
    """
    key = key_for(config)
    verifier = None if key is None else Verifier(key)
    medium = open_medium(config, poll_interval=0.02)
    try:
        medium.filter_as_tap()
        limit = time.monotonic() + timeout
        while time.monotonic() < limit:
            raw = medium.receive()
            if raw is not None and verifier is not None:
                raw = verifier.open(raw)
            if raw is None:
                continue
            try:
                header = parse_header(raw)
                if header.kind != FrameKind.beacon:
                    continue
                _, members = parse_table(raw[HEADER_SIZE:])
            except FrameError:
                continue
            view = BusView(header.generation, members)
            if accept(view):
                return view
        return None
    finally:
        medium.close()


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
