"""What every fuzz target offers: send packets, observe replies, say whether it lives.

A target takes a short batch of packets (a case, maybe a read-back, maybe the
liveness probe) and returns what came back for each. Targets behind a
transport cannot tell silence from slowness, so they need the batch to end
with a packet that is sure to be answered (the *fence*): once its reply is
in, every reply to the packets before it is in too, and silence is known
without waiting for a timeout.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple, Protocol

from fw1394.engine import Reply
from fw1394.errors import BusUnreachable, Error
from fw1394.packets import AsyncPacket


class Wire(NamedTuple):
    """A packet as sent: wire bytes, and how the node's decoder reads them."""

    raw: bytes
    #: ``None``: no packet can be made of the bytes.
    packet: AsyncPacket | None
    #: The packet has CRC or length problems.
    damaged: bool


class Observation(NamedTuple):
    """What came back for one packet (the shape of :class:`fw1394.engine.Reply`)."""

    #: The ack code, ``None`` for none (or when the transport shows no acks).
    ack: int | None
    #: The response: a packet (in-process) or its wire bytes (remote), or None.
    response: AsyncPacket | bytes | None
    #: The response came in the same bus tenure as the ack.
    concatenated: bool


SILENCE = Observation(None, None, False)
#: In-process targets hand back the responder's own replies as they are.
Observed = Observation | Reply


@dataclass(frozen=True)
class Visibility:
    """What a transport lets the fuzzer see of a reply."""

    #: Acks travel back (the Eth1394 framing has none).
    acks: bool = True
    #: Whether a response shared the ack's bus tenure can be told.
    tenure: bool = True
    #: Write responses travel back (Eth1394 never answers a write).
    write_responses: bool = True
    #: Responses carry CRCs that must be right (the JHU FPGA's Ethernet path
    #: sends zeros).
    response_crcs: bool = True
    #: The largest response (wire bytes) a datagram can carry; a node cannot send
    #: a bigger one however right it would be (a 64 KiB block read, say).
    max_response: int = 1 << 20


class TargetCrash(Error):
    """The target raised or its process went away; the message says how."""


class TargetGone(BusUnreachable):
    """The target stopped answering for good; the campaign cannot go on."""


class Target(Protocol):
    """A node under test."""

    #: ``inproc:qla1``, ``bus:default/0``, ``udp:127.0.0.1:1394``...
    description: str
    visibility: Visibility
    #: Batches must end with a fence (see the module documentation).
    needs_fence: bool
    #: :meth:`restart` gives a fresh node (replays and shrinking need one).
    restartable: bool
    #: The node's 16-bit ID.
    node_id: int

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        """Send ``batch`` in order at time ``now``; what came back for each packet.

        Raises :class:`TargetCrash` when the node raised or its process died.
        """
        ...

    def problem(self) -> str | None:
        """Why the node's process is not healthy (gone, renumbered), or None."""
        ...

    def restart(self) -> None:
        """A fresh node in place of this one (restartable targets only)."""
        ...

    def close(self) -> None: ...
