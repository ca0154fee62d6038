"""The Ethernet path of one FPGA1394 board (the firmware's EthernetIO), sans-IO.

A request datagram comes in with the address it came from and the time;
what goes out is a list of actions for the owner to carry out:

* :class:`Reply`: a datagram for the host (a response with zero CRCs and
  the extra bytes, a forwarded FireWire response, or the 8-byte "dropped"
  notice);
* :class:`Forward`: the 1394 packet, as received, for the FireWire bus;
* :class:`HubBroadcast`: this board's real-time block after a broadcast
  query, for the other boards' hubs.

Locality follows the firmware (jhu-eth1394.md §3.2): the node a request must
name is the board ID when the no-forward flag is set, else the FireWire
node ID. Local: the request names it, or is a broadcast write, or is a
broadcast read with no-forward set reaching the Ethernet hub. Remote (sent
to FireWire): it names another node and no-forward is clear; broadcast
writes without no-forward are both. Without no-forward, a bus reset or a
generation mismatch (unless broadcast) drops the packet: reads get the
extra-only notice, writes nothing. No 1394 CRC is checked on this path, and
responses carry zero CRCs.

A quadlet read whose 1394 part is exactly its three header quadlets (12 bytes,
no CRC quadlet) is the stale-data read (jhu-eth1394.md §3.2, an RTL reading):
the last word the UDP length announces is the word at which the packet becomes
"fresh", and that check wins, so no register read starts while a reply is still
owed. The reply is a normal quadlet response (this request's label and source)
carrying whatever the previous read left behind: here the data of the board's
last quadlet read over Ethernet, 0 after power-up. The register is not read.
"""

from __future__ import annotations

import contextlib
import functools
import struct
from dataclasses import dataclass, field

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.firewire import (
    FireWireState,
    broadcast_sequence,
    hub_broadcast,
    is_hub_query,
)
from fw1394.boards.qla1.paths import ETHERNET_PATH, zero_crc_block_response, zero_crc_bytes
from fw1394.boards.qla1.regs import (
    HUB_MEMORY_BASE,
    BoardRegister,
)
from fw1394.engine import Responder
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    PacketError,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    Request,
    Response,
)
from fw1394.packets.asynchronous import tcode_of
from fw1394.packets.enums import TCode
from fw1394.packets.eth1394 import (
    Eth1394Error,
    Eth1394Request,
    ExtraBytes,
)
from fw1394.packets.eth1394_fast import extra_bytes, split_request
from fw1394.packets.fast import decode_packet
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS
from fw1394.packets.nodeid import node_id as node_id_of

HostAddress = tuple[str, int]
#: What an offset reaches over this path (no CSR window: only bits 15..0 arrive).
_ethernet_address = functools.lru_cache(maxsize=4096)(ETHERNET_PATH.decoding.address)
#: The request as a board's responder gets it (the host repeats the same few requests).
_for_board = functools.lru_cache(maxsize=4096)(ETHERNET_PATH.for_board)
#: Quadlet 2 of the unasked broadcast-read response: the hub memory offset.
BROADCAST_RESPONSE_Q2 = HUB_MEMORY_BASE
#: ETH_STATUS write bit that clears the sticky error flags.
CLEAR_ERRORS = 1 << 29
#: How long a read of hub memory waits for missing boards (emulator latency, not firmware).
HUB_READ_WAIT = 0.015
#: Early hub broadcasts kept for a query not seen yet.
STASH_LIMIT = 64

_READS = (QuadletReadRequest, BlockReadRequest)
_RESPONSE_TCODES = (TCode.read_quadlet_response, TCode.read_block_response)
_WRITES = (QuadletWriteRequest, BlockWriteRequest)


@functools.lru_cache(maxsize=64)
def _quadlets(data: bytes) -> tuple[int, ...]:
    # Every board of a rack stores the same broadcast: unpacked once.
    return struct.unpack_from(f">{len(data) // 4}I", data)


@dataclass(frozen=True)
class Reply:
    """A datagram for the host: ``packet`` (empty for extra-only) then ``extra``."""

    address: HostAddress
    packet: bytes
    extra: ExtraBytes
    received_at: float


@dataclass(frozen=True)
class Forward:
    """A request for the FireWire bus, bytes as they arrived."""

    packet: Request
    raw: bytes


@dataclass(frozen=True)
class HubBroadcast:
    """This board's block after a broadcast query, for the hubs of the other boards."""

    packet: BlockWriteRequest


Action = Reply | Forward | HubBroadcast


def datagram(reply: Reply, processed_at: float, sent_at: float) -> bytes:
    """The UDP payload of ``reply`` with its two timers filled in (49.152 MHz ticks)."""
    received = reply.received_at
    return reply.packet + extra_bytes(
        reply.extra, _timer_ticks(processed_at - received), _timer_ticks(sent_at - received)
    )


def _timer_ticks(seconds: float) -> int:
    """A 16-bit timer of the extra bytes: ticks, held at 0 and at its top."""
    return min(max(int(seconds * TICKS_PER_SECOND), 0), 0xFFFF)


def decode_request(raw: bytes) -> Request | None:
    """The request in ``raw``, read as leniently as the firmware does; None if unreadable."""
    packet, _ = ETHERNET_PATH.read(raw)
    return packet if isinstance(packet, Request) else None


@dataclass
class _PendingRead:
    request: BlockReadRequest
    reply_node: int
    no_forward: bool
    address: HostAddress
    received_at: float
    deadline: float


@dataclass
class _BroadcastReadTarget:
    """Where the unasked broadcast-read response goes, and what it must carry."""

    address: HostAddress
    tlabel: int
    requester: int
    sequence: int
    received_at: float


@dataclass
class EthernetPort:
    """The Ethernet side of one board.

    ``responder`` serves the board (shared with its FireWire side);
    ``ethernet_hub`` marks the board nearest the host, the one that answers
    broadcast reads and sends the unasked broadcast-read response.
    """

    board: Qla1Board
    responder: Responder
    firewire: FireWireState
    ethernet_hub: bool = True
    hub_read_wait: float = HUB_READ_WAIT
    #: Sticky "summary error" (extra byte 0 bit 3): a packet with a foreign bus ID.
    summary_error: bool = False
    last_host: HostAddress | None = None
    host_id: int | None = None
    #: What the last quadlet read over Ethernet returned: the stale read's answer.
    last_read: int = 0
    _pending: list[_PendingRead] = field(default_factory=list)
    _broadcast_read: _BroadcastReadTarget | None = None
    _stash: dict[int, list[BlockWriteRequest]] = field(default_factory=dict)

    # -- requests from the host ------------------------------------------------------------
    def receive(self, payload: bytes, sender: HostAddress, now: float) -> list[Action]:
        try:
            framed = split_request(payload)
        except Eth1394Error:
            return []
        return self.receive_framed(framed, sender, now)

    def receive_framed(
        self, framed: Eth1394Request, sender: HostAddress, now: float
    ) -> list[Action]:
        """:meth:`receive` of a datagram split into control word and packet already."""
        stale = ETHERNET_PATH.stale_read(framed.packet)
        packet = stale if stale is not None else decode_request(framed.packet)
        if packet is None:
            return []  # never "fresh": ignored
        if packet.destination_bus != LOCAL_BUS:
            self.summary_error = True  # the firmware's DestError, seen only in later extras
            return []
        control = framed.control
        self.last_host, self.host_id = sender, packet.source_id
        destination = packet.destination_node
        broadcast = destination == BROADCAST_PHY
        is_read = isinstance(packet, _READS)
        firewire = self.firewire
        if not control.no_forward and (
            firewire.resetting
            or (control.bus_generation != firewire.generation & 0xFF and not broadcast)
        ):
            if not is_read:
                return []
            dropped = self._extra(False, packet_dropped=True)
            return [Reply(sender, b"", dropped, now)]
        expected = self.board.board_id if control.no_forward else firewire.node_id
        # Only the Ethernet hub answers broadcast reads, and only with no-forward.
        hub_read = control.no_forward and self.ethernet_hub
        local = ETHERNET_PATH.takes(packet, expected) and (
            not broadcast or isinstance(packet, _WRITES) or hub_read
        )
        actions: list[Action] = []
        if destination != expected and not control.no_forward:
            actions.append(Forward(packet, framed.packet))
        if local:
            reply_node = self.board.board_id if control.no_forward else firewire.node_id
            if stale is not None:
                return [*actions, self._stale(stale, reply_node, control.no_forward, sender, now)]
            actions += self._serve(packet, reply_node, control.no_forward, sender, now)
        return actions

    def _stale(
        self,
        packet: QuadletReadRequest,
        reply_node: int,
        no_forward: bool,
        sender: HostAddress,
        now: float,
    ) -> Reply:
        """The reply to a 12-byte quadlet read: no register read, the last read's data."""
        stale = ETHERNET_PATH.stale_response(packet, self.last_read)
        response = ETHERNET_PATH.answer(stale, packet, reply_node)
        return Reply(sender, zero_crc_bytes(response), self._extra(no_forward), now)

    def _serve(
        self,
        packet: Request,
        reply_node: int,
        no_forward: bool,
        sender: HostAddress,
        now: float,
    ) -> list[Action]:
        target = _for_board(packet, self.responder.node_id & BROADCAST_PHY)
        if isinstance(target, BlockReadRequest) and self._hub_round_waiting(target):
            deadline = now + self.hub_read_wait
            self._pending.append(
                _PendingRead(target, reply_node, no_forward, sender, now, deadline)
            )
            return []
        actions = self._answer(target, reply_node, no_forward, sender, now)
        if isinstance(packet, QuadletWriteRequest):
            actions += self._after_write(packet, no_forward, sender, now)
        return actions

    def _answer(
        self,
        target: Request,
        reply_node: int,
        no_forward: bool,
        sender: HostAddress,
        now: float,
    ) -> list[Action]:
        reply = self.responder.receive_packet(target, now, damaged=False)
        response = reply.response
        if response is None or not isinstance(response, Response):
            return []
        if _plain_block_response(response):
            # The hub read of every bridge-mode cycle: its header is encoded once.
            assert isinstance(response, BlockReadResponse)
            source = ETHERNET_PATH.answer_source(target, reply_node)
            raw = zero_crc_block_response(
                response.destination_id,
                response.tlabel,
                response.source_id if source is None else source,
                response.reserved,
                response.data,
            )
            return [Reply(sender, raw, self._extra(no_forward), now)]
        response = ETHERNET_PATH.answer(response, target, reply_node)
        if isinstance(response, QuadletReadResponse):
            self.last_read = response.quadlet_data
        return [Reply(sender, zero_crc_bytes(response), self._extra(no_forward), now)]

    def _after_write(
        self, packet: QuadletWriteRequest, no_forward: bool, sender: HostAddress, now: float
    ) -> list[Action]:
        index = _ethernet_address(packet.offset)
        if index == BoardRegister.ETH_STATUS and packet.quadlet_data & CLEAR_ERRORS:
            self.summary_error = False
        if not is_hub_query(packet):
            return []
        return self.query_taken(now, packet if no_forward else None, sender)

    # -- the broadcast query and the hub ---------------------------------------------------
    def query_taken(
        self,
        now: float,
        query: QuadletWriteRequest | None = None,
        sender: HostAddress | None = None,
    ) -> list[Action]:
        """The board has just taken a broadcast query (from Ethernet or FireWire).

        ``query`` is given for an Ethernet-only query (no-forward set), whose
        answer the hub sends unasked to ``sender``.
        """
        hub = self.board.hub
        actions: list[Action] = []
        own = hub_broadcast(self.board, self.firewire.node_id)
        if own is not None:
            actions.append(HubBroadcast(own))
        if query is not None and sender is not None and self.ethernet_hub:
            self._broadcast_read = _BroadcastReadTarget(
                sender, query.tlabel, query.source_id, hub.sequence, now
            )
        for early in self._stash.pop(hub.sequence, []):
            self._store(early, now)
        self._stash.clear()  # anything else belongs to a round that is over
        return actions + self._round_progress(now)

    def hub_block(self, packet: BlockWriteRequest, now: float) -> list[Action]:
        """Another board's hub broadcast (over FireWire, or the Ethernet-only exchange)."""
        sequence = broadcast_sequence(packet)
        hub = self.board.hub
        if sequence is None:
            return []
        if sequence != hub.sequence or not hub.board_mask:
            # Its query has not reached this board yet: keep it for then.
            if len(self._stash) < STASH_LIMIT:
                self._stash.setdefault(sequence, []).append(packet)
            return []
        self._store(packet, now)
        return self._round_progress(now)

    def _store(self, packet: BlockWriteRequest, now: float) -> None:
        # A hub broadcast is a broadcast block write to hub memory: written as the
        # responder would (clock first), without screening it again per board.
        board, ticks = self.board, int(now * TICKS_PER_SECOND)
        if ticks > board.now:
            board.set_time(ticks)
        board.store_hub_broadcast(_quadlets(packet.data))

    def _hub_round_waiting(self, request: BlockReadRequest) -> bool:
        hub = self.board.hub
        return (
            self.hub_read_wait > 0
            and _ethernet_address(request.offset) == HUB_MEMORY_BASE
            and bool(hub.board_mask)
            and not hub.complete
        )

    def _round_progress(self, now: float) -> list[Action]:
        hub = self.board.hub
        actions: list[Action] = []
        target = self._broadcast_read
        if hub.complete and target is not None and target.sequence == hub.sequence:
            self._broadcast_read = None
            actions.append(self._broadcast_response(target, now))
        waiting = []
        for pending in self._pending:
            if hub.complete or now >= pending.deadline:
                actions += self._answer(
                    pending.request,
                    pending.reply_node,
                    pending.no_forward,
                    pending.address,
                    now,
                )
            else:
                waiting.append(pending)
        self._pending = waiting
        return actions

    @property
    def quiet(self) -> bool:
        """Nothing of an earlier round in flight: no early hub broadcast kept, no hub read
        waiting, no unasked broadcast-read response owed."""
        return not self._stash and not self._pending and self._broadcast_read is None

    def answer_query(self, query: QuadletWriteRequest, sender: HostAddress, now: float) -> Reply:
        """The unasked response to the Ethernet-only ``query`` (received at ``now`` from
        ``sender``) once its round is complete on this hub: what :meth:`query_taken` and
        the other boards' blocks end with, for a rack that served the round itself."""
        self._broadcast_read = None
        hub = self.board.hub
        target = _BroadcastReadTarget(sender, query.tlabel, query.source_id, hub.sequence, now)
        return self._broadcast_response(target, now)

    def _broadcast_response(self, target: _BroadcastReadTarget, now: float) -> Reply:
        # The responder's space is a ClockedBoard: setting the time never goes back.
        self.responder.space.set_time(int(now * TICKS_PER_SECOND))
        data = self.board.broadcast_read_data() or b""
        response = zero_crc_block_response(
            target.requester,
            target.tlabel,
            node_id_of(self.board.board_id),
            BROADCAST_RESPONSE_Q2,
            data,
        )
        return Reply(target.address, response, self._extra(True), target.received_at)

    # -- FireWire side and timers -----------------------------------------------------------
    def firewire_response(self, raw: bytes, now: float) -> list[Action]:
        """A response seen on FireWire: relayed as it is if it is addressed to the host."""
        if self.last_host is None or len(raw) < 4 or tcode_of(raw) not in _RESPONSE_TCODES:
            return []
        packet: AsyncPacket | None = None
        with contextlib.suppress(PacketError):
            packet = decode_packet(raw)
        if not isinstance(packet, Response) or packet.destination_id != self.host_id:
            return []
        return [Reply(self.last_host, raw, self._extra(False), now)]

    def poll(self, now: float) -> list[Action]:
        """Answer hub reads whose wait is over."""
        return self._round_progress(now) if self._pending else []

    def next_deadline(self) -> float | None:
        if not self._pending:
            return None
        return min(pending.deadline for pending in self._pending)

    def _extra(self, no_forward: bool, *, packet_dropped: bool = False) -> ExtraBytes:
        firewire = self.firewire
        return _extra_bytes(
            firewire.resetting,
            packet_dropped,
            self.summary_error,
            no_forward,
            firewire.generation & 0xFF,
        )


# Every reply carries extra bytes, and they take few values: each is made once.
@functools.lru_cache(maxsize=1024)
def _extra_bytes(
    bus_reset: bool, packet_dropped: bool, summary_error: bool, no_forward: bool, generation: int
) -> ExtraBytes:
    return ExtraBytes(
        bus_reset=bus_reset,
        packet_dropped=packet_dropped,
        summary_error=summary_error,
        no_forward_echo=no_forward,
        fpga_bus_generation=generation,
    )


def _plain_block_response(response: Response) -> bool:
    """A complete block read response with nothing else set: what
    :func:`zero_crc_block_response` encodes."""
    return type(response) is BlockReadResponse and response == BlockReadResponse(
        destination_id=response.destination_id,
        tlabel=response.tlabel,
        source_id=response.source_id,
        reserved=response.reserved,
        data=response.data,
    )
