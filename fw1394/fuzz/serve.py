"""A board behind a point-to-point UDP tunnel: the other end of ``udp:`` fuzz targets.

``fw1394 fuzz serve`` runs this in its own process, so the fuzzer (and the
benchmark) can reach a node the way it reaches a board on a lab network:

* tunnel framing: an ``async_packet`` frame in, an ``ack`` frame back to the
  sender's address (the response concatenated when the policy says so), a
  split response as a frame of its own;
* Eth1394 framing: a request datagram in, a response datagram (packet and 8
  extra bytes) back for reads and locks, nothing for writes.

It serves one node with :class:`~fw1394.engine.defects.DefectiveResponder`, so
planted defects work here as in-process. Loopback addresses only.
"""

from __future__ import annotations

import contextlib
import ipaddress
import socket
import time

from fw1394.engine import ResponderPolicy
from fw1394.engine.defects import PACKET_DEFECTS, DefectiveResponder
from fw1394.errors import UsageError
from fw1394.fuzz.reference import board
from fw1394.packets import WriteResponse
from fw1394.packets.eth1394 import (
    CONTROL_WORD_SIZE,
    Eth1394Response,
    ExtraBytes,
    build_response,
)
from fw1394.packets.fast import encode_packet
from fw1394.transport.link import ResponderLink
from fw1394.transport.sansio.wire import HEADER_SIZE, FrameError, FrameHeader, parse_header

MAX_DATAGRAM = 65_535
#: The receive timeout: how often the loop looks at its deadline.
_POLL = 0.1
_NODE_PHY_MEMBER = 0x4E4F4445  # "NODE": the member ID this end puts in its frames
#: The 8 extra bytes after every response (built once by the framing's codec): the
#: no-forward flag echoed, so a host does not take a generation change for a reset.
_EXTRA = build_response(Eth1394Response(b"", ExtraBytes(no_forward_echo=True)))


class ServeError(UsageError):
    """An address this server will not use (one line for the user)."""


def loopback_address(text: str) -> tuple[str, int]:
    """``HOST:PORT`` on 127.0.0.0/8 (port 0: any free one), as a socket address."""
    host, colon, port = text.rpartition(":")
    if not colon or not port.isdigit() or not 0 <= int(port) < 65536:
        raise ServeError(f"listen address {text!r}: use HOST:PORT")
    try:
        if not ipaddress.IPv4Address(host).is_loopback:
            raise ServeError(f"listen address {host}: only loopback (127.0.0.0/8) is served")
    except ipaddress.AddressValueError:
        raise ServeError(f"listen address {host!r} is not an IPv4 address") from None
    return host, int(port)


class TunnelNode:
    """Board ``kind`` as node ``node_id`` on a UDP socket bound to ``address``."""

    def __init__(
        self,
        address: tuple[str, int],
        kind: str,
        *,
        board_id: int,
        node_id: int,
        policy: ResponderPolicy,
        defects: frozenset[str] = frozenset(),
        eth1394: bool = False,
    ) -> None:
        board_defects = frozenset() if kind == "memory" else defects - PACKET_DEFECTS.keys()
        space = board(kind, board_id, board_defects)
        self.responder = DefectiveResponder(node_id, space, policy, defects=defects)
        self.eth1394 = eth1394
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind(address)
            self.sock.settimeout(_POLL)
        except OSError:
            self.sock.close()
            raise
        self.address = self.sock.getsockname()
        self.link = ResponderLink(self.responder, self._send, epoch=time.monotonic())
        self._sequence = 0
        # The frame being answered and its sender's address: replies echo its tag and
        # generation (a tunnel has no bus of its own) and go back where it came from.
        self._to: tuple[FrameHeader, tuple[str, int]] | None = None

    def serve(self, duration: float | None = None) -> None:
        """Answer datagrams until ``duration`` seconds have passed (forever: None)."""
        end = None if duration is None else time.monotonic() + duration
        sock = self.sock
        while end is None or time.monotonic() < end:
            try:
                datagram, sender = sock.recvfrom(MAX_DATAGRAM)
            except TimeoutError:
                continue
            now = time.monotonic()
            if self.eth1394:
                self._eth1394(datagram, sender, now - self.link.epoch)
            else:
                self._tunnel(datagram, sender, now)

    def close(self) -> None:
        self.sock.close()

    def _eth1394(self, datagram: bytes, sender: tuple[str, int], now: float) -> None:
        if len(datagram) < CONTROL_WORD_SIZE:
            return
        reply = self.responder.receive(datagram[CONTROL_WORD_SIZE:], now)
        response = reply.response
        if response is None or isinstance(response, WriteResponse):
            return  # Eth1394 never answers a write
        self._send_datagram(encode_packet(response) + _EXTRA, sender)

    def _tunnel(self, datagram: bytes, sender: tuple[str, int], now: float) -> None:
        try:
            header = parse_header(datagram)
        except FrameError:
            return
        self._to = (header, sender)
        self.link.take(header, datagram[HEADER_SIZE:], now)

    def _send(self, kind: int, destination: int, payload: bytes) -> None:
        assert self._to is not None, "a tunnel only answers"
        to, address = self._to
        self._sequence = (self._sequence + 1) & 0xFFFFFFFF
        frame = FrameHeader(
            kind,
            tag=to.tag,
            sender=_NODE_PHY_MEMBER,
            generation=to.generation,
            sender_phy=to.destination,
            destination=destination,
            sequence=self._sequence,
        )
        self._send_datagram(frame.pack() + payload, address)

    def _send_datagram(self, datagram: bytes, to: tuple[str, int]) -> None:
        # A reply too big for one datagram (a 64 KiB block read) cannot travel:
        # dropped, as a link drops what it cannot send.
        with contextlib.suppress(OSError):
            self.sock.sendto(datagram, to)
