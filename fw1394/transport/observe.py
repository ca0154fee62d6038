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
from fw1394.transport.medium import Medium
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
    """The first beacon within ``timeout`` seconds whose view ``accept`` likes."""
    medium = Medium(config, poll_interval=0.02)
    try:
        medium.filter_as_tap()
        limit = time.monotonic() + timeout
        while time.monotonic() < limit:
            raw = medium.receive()
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


def request_reset(config: BusConfig) -> None:
    """Ask whoever coordinates the bus for a bus reset."""
    medium = Medium(config)
    try:
        header = FrameHeader(
            FrameKind.reset_request,
            config.tag,
            secrets.randbits(32) or 1,
            0,
            NO_PHY,
            EVERY_MEMBER,
        )
        medium.send(header.pack())
    finally:
        medium.close()
