"""Isochronous channels among the host adapter's clients.

A program that transmits on a channel hands the adapter each stream packet's
payload, tag and sy; every client listening to that channel gets it, with
the cycle it went out in. The bus's members (the boards) have no
isochronous side, so the packets travel only between the programs sharing
the adapter, as between two programs on one PC's controller.
"""

from __future__ import annotations

from collections.abc import Hashable

from construct import GreedyBytes, Int8ub, Int16ub, Struct

from fw1394.transport.host_adapter.local_node import Push

#: A received stream packet (``data`` of a push to an ``iso_listen`` request).
ISO_PACKET = Struct(
    "channel" / Int8ub,
    "tag" / Int8ub,
    "sy" / Int8ub,
    "reserved" / Int8ub,
    "cycle" / Int16ub,  # the cycle count (0-7999) it was sent in
    "data" / GreedyBytes,
)
CHANNELS = 64


class IsoChannels:
    """Who listens to which of the 64 channels."""

    def __init__(self) -> None:
        #: owner -> (the number of its listen request, its channel mask)
        self.listeners: dict[Hashable, tuple[int, int]] = {}

    def listen(self, owner: Hashable, number: int, mask: int) -> None:
        """``owner`` hears the channels of ``mask`` (bit n: channel n); 0: none."""
        if not 0 <= mask < 1 << CHANNELS:
            raise ValueError(f"channel mask 0x{mask:x} is not 64 bits")
        if mask:
            self.listeners[owner] = (number, mask)
        else:
            self.listeners.pop(owner, None)

    def forget(self, owner: Hashable) -> None:
        self.listeners.pop(owner, None)

    def send(self, channel: int, tag: int, sy: int, data: bytes, cycle: int) -> list[Push]:
        """A stream packet on ``channel``: one push per listener."""
        if not 0 <= channel < CHANNELS or not 0 <= tag < 4 or not 0 <= sy < 16:
            raise ValueError(f"no stream packet has channel {channel}, tag {tag}, sy {sy}")
        record: bytes = ISO_PACKET.build(
            {"channel": channel, "tag": tag, "sy": sy, "reserved": 0, "cycle": cycle, "data": data}
        )
        return [
            Push(owner, number, record)
            for owner, (number, mask) in self.listeners.items()
            if mask >> channel & 1
        ]
