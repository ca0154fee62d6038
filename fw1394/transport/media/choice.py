"""Which medium carries a bus: shared memory on one host, UDP multicast across hosts.

Both carry the same frames (:mod:`fw1394.packets.frame`) with the same
semantics (``docs/virtual-bus.md``, "Media"). Every bus uses the UDP medium
(:class:`~fw1394.transport.media.udp.Medium`) unless ``FW1394_MEDIUM=shm`` puts a
bus that lives on one host on
:class:`~fw1394.transport.media.shared_memory.SharedMedium`: measured on the
two-core development machine, interleaved in the same rounds, the ring was
no faster than UDP and cost as much CPU per read (``docs/virtual-bus.md``,
"Performance"), so the default goes by that measurement. Every member of one
bus must use the same medium.
"""

from __future__ import annotations

import os
import socket
from collections.abc import Callable
from typing import Protocol

from fw1394.errors import UsageError
from fw1394.transport.media.idle import BLOCK, IdleStrategy
from fw1394.transport.media.shared_memory import SharedMedium
from fw1394.transport.media.udp import Medium
from fw1394.transport.sansio.config import BusConfig

ENVIRONMENT = "FW1394_MEDIUM"
SHARED, UDP = "shm", "udp"
NAMES = (SHARED, UDP)


class BusMedium(Protocol):
    """What a bus member needs of its medium."""

    config: BusConfig
    idle: IdleStrategy

    @property
    def sock(self) -> socket.socket: ...

    def send(self, frame: bytes) -> None: ...

    def receive(self) -> bytes | None: ...

    def receive_queued(self) -> bytes | None: ...

    def receive_stamped(self, wait: bool = True) -> tuple[bytes, int] | None: ...

    def filter_as_member(self, member_id: int, phy_id: int | None, drop_acks: bool) -> None: ...

    def filter_as_tap(self) -> None: ...

    def sleep_until(self, deadline: Callable[[], float]) -> None: ...

    def share_host(self, members: int) -> None: ...

    def close(self) -> None: ...


def medium_name(config: BusConfig) -> str:
    """``shm`` or ``udp``: what ``FW1394_MEDIUM`` says, else ``udp``.

    Shared memory only carries a bus on one host: ``shm`` for a bus on a LAN
    interface, or an unknown name, is a :class:`~fw1394.errors.UsageError`.
    """
    chosen = os.environ.get(ENVIRONMENT, "").strip().lower() or UDP
    if chosen not in NAMES:
        raise UsageError(f"{ENVIRONMENT}={chosen!r}: expected {' or '.join(NAMES)}")
    if chosen == SHARED and not config.interface.startswith("127."):
        raise UsageError(
            f"{ENVIRONMENT}=shm carries a bus on one host; {config.interface} is a LAN interface"
        )
    return chosen


def open_medium(
    config: BusConfig, poll_interval: float = 0.005, idle: IdleStrategy = BLOCK
) -> BusMedium:
    """The medium of the bus ``config`` (:func:`medium_name`), open."""
    if medium_name(config) == SHARED:
        return SharedMedium(config, poll_interval, idle)
    return Medium(config, poll_interval, idle)
