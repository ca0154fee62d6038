"""``udp:HOST[:PORT]``: a node behind a UDP tunnel, however it is implemented.

Two framings, both point to point:

* fw1394's tunnel frames (``docs/virtual-bus.md``): each case goes out as an
  ``async_packet`` frame (bus tag 0, generation 0, sender physical ID 62,
  destination the node's physical ID); the node answers with ``ack`` frames
  naming the frame's sequence number, and split responses as packets;
* the JHU Eth1394 framing (``eth1394=True``): a control word with the
  no-forward flag (the board itself answers, nothing is forwarded onto
  FireWire) and the packet; the node sends response datagrams for reads and
  nothing for writes, so acks are invisible and responses carry zero CRCs.

Nothing here depends on the node being fw1394's: any implementation that
speaks one of the framings can be fuzzed.
"""

from __future__ import annotations

import itertools
import secrets
import socket
import time

from fw1394.fuzz.target import Observed, TargetCrash, TargetGone, Visibility, Wire
from fw1394.fuzz.tunnel import Replies
from fw1394.packets.eth1394 import (
    EXTRA_SIZE,
    UDP_PORT,
    ControlWord,
    Eth1394Request,
    build_request,
)
from fw1394.packets.nodeid import phy_of
from fw1394.transport.sansio.wire import (
    ACK_PAYLOAD,
    HEADER_SIZE,
    MAX_UDP_PAYLOAD,
    FrameError,
    FrameHeader,
    FrameKind,
    parse_header,
)
from fw1394.transport.supervision.procs import process_alive

#: The sender's physical ID in tunnel frames: the highest node, where a host sits.
HOST_PHY = 62
MAX_DATAGRAM = 65_535
ETH1394_VISIBILITY = Visibility(
    acks=False,
    tenure=False,
    write_responses=False,
    response_crcs=False,
    max_response=MAX_UDP_PAYLOAD - EXTRA_SIZE,
)
#: An ack frame carries the concatenated response after its header and ack payload.
TUNNEL_VISIBILITY = Visibility(max_response=MAX_UDP_PAYLOAD - HEADER_SIZE - ACK_PAYLOAD.size)
#: The control word of every request (built by the framing's own codec, once):
#: no-forward set, so the board answers itself and forwards nothing to FireWire.
_CONTROL_WORD = build_request(Eth1394Request(ControlWord(no_forward=True), b""))


class UdpTarget:
    """The node at ``address`` (host, port) with 16-bit ID ``node_id``."""

    restartable = False
    needs_fence = True

    def __init__(
        self,
        address: tuple[str, int],
        *,
        node_id: int,
        eth1394: bool,
        timeout: float,
        pid: int | None = None,
    ) -> None:
        framing = "eth1394" if eth1394 else "tunnel"
        self.description = f"udp:{address[0]}:{address[1]} ({framing})"
        self.node_id = node_id
        self.eth1394 = eth1394
        self.timeout = timeout
        self.pid = pid
        self.visibility = ETH1394_VISIBILITY if eth1394 else TUNNEL_VISIBILITY
        self._member = secrets.randbits(32) or 1
        self._sequence = itertools.count(1)
        self._late = False
        #: Responses that came after their batch was over (see :class:`Replies`).
        self.late_replies = 0
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.connect(address)
        except OSError:
            self.sock.close()
            raise

    @classmethod
    def open(
        cls, spec: str, *, node_id: int, eth1394: bool, timeout: float, pid: int | None = None
    ) -> UdpTarget:
        """``spec`` is ``HOST[:PORT]`` (port 1394, the Eth1394 port, by default)."""
        host, colon, port = spec.partition(":")
        if not host or (colon and not port.isdigit()) or (port and not 0 < int(port) < 65536):
            raise TargetGone(f"udp target {spec!r}: use udp:HOST[:PORT]")
        try:
            address = socket.gethostbyname(host)
        except OSError as error:
            raise TargetGone(f"udp target {host!r}: {error}") from None
        return cls(
            (address, int(port) if port else UDP_PORT),
            node_id=node_id,
            eth1394=eth1394,
            timeout=timeout,
            pid=pid,
        )

    # -- framing ------------------------------------------------------------------------
    def _frame(self, raw: bytes) -> tuple[bytes, int]:
        if self.eth1394:
            return _CONTROL_WORD + raw, 0
        sequence = next(self._sequence) & 0xFFFFFFFF
        header = FrameHeader(
            FrameKind.async_packet,
            tag=0,
            sender=self._member,
            generation=0,
            sender_phy=HOST_PHY,
            destination=phy_of(self.node_id),
            sequence=sequence,
        )
        return header.pack() + raw, sequence

    def _take(self, datagram: bytes, replies: Replies) -> None:
        if self.eth1394:
            if len(datagram) > EXTRA_SIZE:  # not the "read dropped" notice
                replies.on_response(datagram[:-EXTRA_SIZE], acked=False)
            return
        try:
            header = parse_header(datagram)
        except FrameError:
            return
        payload = datagram[HEADER_SIZE:]
        if header.kind == FrameKind.ack:
            replies.on_ack(payload)
        elif header.kind == FrameKind.async_packet:
            replies.on_response(payload)

    # -- the Target protocol ------------------------------------------------------------
    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        if self._late:
            self._drain()
        sequences = []
        try:
            for wire in batch:
                datagram, sequence = self._frame(wire.raw)
                sequences.append(sequence)
                self.sock.send(datagram)
        except ConnectionRefusedError:
            raise TargetCrash("process-gone: nothing listens at the target's port") from None
        replies = Replies(batch, None if self.eth1394 else sequences)
        acks = not self.eth1394
        limit = time.monotonic() + self.timeout
        while not replies.complete(acks=acks):
            left = limit - time.monotonic()
            if left <= 0:
                break
            self.sock.settimeout(left)
            try:
                datagram = self.sock.recv(MAX_DATAGRAM)
            except TimeoutError:
                break
            except ConnectionRefusedError:
                raise TargetCrash("process-gone: nothing listens at the target's port") from None
            self._take(datagram, replies)
        # Replies still on their way would be taken for the next batch's.
        self._late = not replies.complete(acks=acks)
        self.late_replies += replies.late
        return list(replies.observations())

    def _drain(self) -> None:
        # The last batch went unanswered in time: its replies may still be on their
        # way. Give them the batch's time again, so none is taken for this batch's.
        self.sock.settimeout(self.timeout)
        try:
            while True:
                self.sock.recv(MAX_DATAGRAM)
                self.late_replies += 1
        except (TimeoutError, BlockingIOError, ConnectionRefusedError):
            pass
        self._late = False

    def problem(self) -> str | None:
        if self.pid is not None and not process_alive(self.pid):
            return f"process-gone: node process {self.pid} has exited"
        return None

    def restart(self) -> None:
        raise TargetGone(f"{self.description} cannot be restarted from here")

    def close(self) -> None:
        self.sock.close()
