"""What the host adapter does as a node, beyond running its clients' transactions.

The adapter (:mod:`fw1394.transport.host_adapter.server`) hands this module the requests
and frames that concern its own node; :class:`NodeServices` serves them with
a :class:`~fw1394.transport.host_adapter.local_node.LocalNode` and carries the answers:
to a client (a reply, or a *push*: a reply that repeats the number of a
client's standing request), or onto the bus (an ack, a response packet).

The operations (``Op``) it owns, and how their fields are used:

* ``watch``: the client hears of every bus reset. The reply, now and after each
  reset (same request number), carries :data:`~fw1394.transport.host_adapter.local_node.BUS_STATE`;
  the reply header's ``generation`` and ``phy`` are the new ones.
* ``listen``: claim ``length`` bytes at ``offset`` of the adapter's node
  (``extended_tcode`` 1: listen to the FCP registers, shared with others). Each
  request into the range is pushed as an :data:`~fw1394.transport.host_adapter.local_node.INCOMING`
  record; ``unlisten`` (``offset``) gives the range back.
* ``respond``: answer the pushed request whose handle is ``offset`` with rcode
  ``extended_tcode`` and ``data``.
* ``cycle_time``: the reply's ``data`` is the CYCLE_TIME register (4 bytes).
* ``config_rom``: with no ``data``, the reply carries
  :data:`~fw1394.transport.host_adapter.local_node.ROM_IMAGE`; with ``data``, that becomes the
  ROM if ``length`` is the version the client read (a changed ROM resets the bus).
* ``reset``: ask for a bus reset.
* ``add_descriptor``: add ``data`` (whole ROM blocks) to the configuration ROM,
  named by a root directory entry of key byte ``length >> 24``, after an immediate
  entry ``offset`` if not 0; the reply's ``data`` is the u32 token.
  ``remove_descriptor`` (``offset``: the token) takes it out again. Both reset the
  bus; a client's descriptors go when it leaves.
* ``iso_send``: a stream packet on channel ``node`` (``extended_tcode``: tag << 4 |
  sy; ``data``: the payload) for every client listening to that channel.
* ``iso_listen``: the client hears the channels of the 64-bit mask ``offset`` (0:
  none); each packet is pushed as an :data:`~fw1394.transport.host_adapter.iso.ISO_PACKET`.

``read``, ``write`` and ``lock`` addressed to the adapter's own physical ID are
served here too, as a PC's kernel serves requests to its own node.
"""

from __future__ import annotations

from collections.abc import Hashable, Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from fw1394.engine.responder import decode_received
from fw1394.packets import (
    AckCode,
    BlockReadResponse,
    LockResponse,
    QuadletReadResponse,
    RCode,
    TCode,
    WriteResponse,
)
from fw1394.packets.accessors import TCODE
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import LOCAL_BUS, is_broadcast
from fw1394.transport.host_adapter.iso import IsoChannels
from fw1394.transport.host_adapter.local_node import Answer, Incoming, LocalNode, Push
from fw1394.transport.host_adapter.protocol import Op, Reply, Request, Status
from fw1394.transport.link import ACK, ACK_BYTES, ASYNC_PACKET
from fw1394.transport.sansio.wire import ACK_PAYLOAD, FrameHeader

if TYPE_CHECKING:
    from fw1394.transport.bus_host import BusHost

#: A connected program, as the adapter keeps it: only passed back to the adapter here.
Client = Hashable


class Adapter(Protocol):
    """What the node's services use of the adapter that owns them (the adapter
    imports this module, so it is named here by what it does, not imported)."""

    @property
    def host(self) -> BusHost: ...

    @property
    def clients(self) -> Mapping[Any, Client]: ...

    def _reply(self, client: Any, reply: Reply) -> None: ...

#: Request tcodes a node answers (the bus's other async tcodes are responses,
#: cycle starts and stream packets).
REQUEST_TCODES = frozenset(
    {
        TCode.write_quadlet_request,
        TCode.write_block_request,
        TCode.read_quadlet_request,
        TCode.read_block_request,
        TCode.lock_request,
    }
)
_FCP = 1


@dataclass(frozen=True, slots=True)
class ToClient:
    """A request of a client to the adapter's own node: answered by a reply."""

    client: Client
    number: int


@dataclass(frozen=True, slots=True)
class ToBus:
    """A request from another node: answered by a response packet on the bus."""

    phy: int
    generation: int
    request: Incoming


def is_request(payload: bytes) -> bool:
    return len(payload) >= 4 and TCODE.of_bytes(payload) in REQUEST_TCODES


class NodeServices:
    """The adapter's node and the clients that watch the bus or claim its addresses."""

    def __init__(self, adapter: Adapter) -> None:
        self.adapter = adapter
        self.node = LocalNode()
        self.iso = IsoChannels()
        self.watchers: dict[Client, int] = {}
        self._seen: tuple[int, int] | None = None

    # -- hooks the adapter calls --------------------------------------------------------
    def handle(self, client: Client, request: Request) -> bool:
        """Serve ``request`` if it is this module's; whether it was."""
        op = request.op
        if op in (Op.read, Op.write, Op.lock):
            if request.node != self.adapter.host.phy_id:
                return False
            self.adapter.host.on_bus()  # raises if the request's generation has ended
            self._own_node(client, request)
            return True
        reply = Reply(request.request, Status.ok)
        node = self.node
        if op is Op.watch:
            self.watchers[client] = request.request
            if self._seen is not None:
                reply = Reply(request.request, Status.ok, data=node.bus_state())
            # Before the first self-ID phase, the first reset's push is the answer.
            else:
                return True
        elif op is Op.listen:
            shared = request.extended_tcode == _FCP
            node.listen(client, request.request, request.offset, request.length, shared)
        elif op is Op.unlisten:
            node.unlisten(client, request.offset)
        elif op is Op.respond:
            path, answer = node.respond(
                client, request.offset, request.extended_tcode, request.data
            )
            self._answer(path, answer)
        elif op is Op.cycle_time:
            reply = Reply(request.request, Status.ok, data=node.cycle_time().to_bytes(4, "big"))
        elif op is Op.config_rom:
            if request.data and node.update_rom(request.data, request.length):
                self.adapter.host.station.request_reset()
            reply = Reply(request.request, Status.ok, data=node.rom_image())
        elif op is Op.reset:
            self.adapter.host.station.request_reset()
        elif op is Op.add_descriptor:
            token = node.add_descriptor(client, request.offset, request.length, request.data)
            reply = Reply(request.request, Status.ok, data=token.to_bytes(4, "big"))
            self.adapter.host.station.request_reset()
        elif op is Op.remove_descriptor:
            node.remove_descriptor(client, request.offset)
            self.adapter.host.station.request_reset()
        elif op is Op.iso_send:
            tag, sy = request.extended_tcode >> 4, request.extended_tcode & 0xF
            cycle = node.cycle_time() >> 12 & 0x1FFF
            self._push(self.iso.send(request.node, tag, sy, request.data, cycle))
        elif op is Op.iso_listen:
            self.iso.listen(client, request.request, request.offset)
        else:
            return False
        self.adapter._reply(client, reply)
        return True

    def from_bus(self, header: FrameHeader, payload: bytes) -> None:
        """A request packet another node sent to this node (or to every node)."""
        packet, damaged = decode_received(payload)
        if packet is None or damaged:
            return  # a link drops what fails its CRCs; the requester times out
        tcode = packet.tcode
        data = getattr(packet, "data", b"")
        if tcode == TCode.write_quadlet_request:
            data = packet.quadlet_data.to_bytes(4, "big")  # type: ignore[attr-defined]
        # Bytes asked for (a block read), or carried (writes, locks); a quadlet read asks 4.
        block_read = tcode == TCode.read_block_request
        length = packet.data_length if block_read else len(data) or 4  # type: ignore[attr-defined]
        incoming = Incoming(
            tcode,
            packet.source_id,  # type: ignore[attr-defined]
            packet.destination_id,  # type: ignore[attr-defined]
            packet.offset,  # type: ignore[attr-defined]
            length,
            data,
            getattr(packet, "extended_tcode", 0),
            packet.tlabel,  # type: ignore[attr-defined]
        )
        path = ToBus(header.sender_phy, header.generation, incoming)
        answer, pushes = self.node.request(incoming, path)
        self._push(pushes)
        if is_broadcast(incoming.destination):
            return  # nobody acks or answers a broadcast
        if answer is None:
            self._ack(header, incoming.tlabel, AckCode.ack_pending)
        elif tcode in (TCode.write_quadlet_request, TCode.write_block_request) and not answer.rcode:
            self._ack(header, incoming.tlabel, AckCode.ack_complete)  # a unified write
        else:
            self._ack(
                header, incoming.tlabel, AckCode.ack_pending, self._response(incoming, answer)
            )

    def after_serve(self) -> None:
        """Tell the watchers of a bus reset the adapter has taken in."""
        host = self.adapter.host
        membership = host.station.membership
        # Plain attributes first: this runs on every turn of the adapter's loop.
        phy, generation = membership.phy_id, membership.generation
        if phy is None or (generation, phy) == self._seen or not membership.ready:
            return
        self._seen = (generation, phy)
        ids = membership.self_ids
        self.node.bus_reset(phy, generation, [ids[p] for p in sorted(ids)])
        state = self.node.bus_state()
        for client, number in list(self.watchers.items()):
            self.adapter._reply(client, Reply(number, Status.ok, data=state))

    def dropped(self, client: Client) -> None:
        self.watchers.pop(client, None)
        self.iso.forget(client)
        if any(d.owner == client for d in self.node.descriptors.values()):
            self.adapter.host.station.request_reset()  # its ROM blocks go with it
        for path, answer in self.node.forget(client):
            self._answer(path, answer)

    # -- answers ------------------------------------------------------------------------
    def _own_node(self, client: Client, request: Request) -> None:
        node_id = self.node.node_id
        if request.op is Op.read:
            tcode = TCode.read_quadlet_request if request.quadlet else TCode.read_block_request
            incoming = Incoming(tcode, node_id, node_id, request.offset, request.length)
        elif request.op is Op.write:
            tcode = TCode.write_quadlet_request if request.quadlet else TCode.write_block_request
            data = request.data
            incoming = Incoming(tcode, node_id, node_id, request.offset, len(data), data)
        else:
            data = request.argument + request.data
            incoming = Incoming(
                TCode.lock_request,
                node_id,
                node_id,
                request.offset,
                len(data),
                data,
                request.extended_tcode,
            )
        answer, pushes = self.node.request(incoming, ToClient(client, request.request))
        self._push(pushes)
        if answer is not None:
            self._answer(ToClient(client, request.request), answer)

    def _answer(self, path: object, answer: Answer) -> None:
        if isinstance(path, ToClient):
            if answer.rcode == RCode.resp_complete:
                reply = Reply(path.number, Status.ok, data=answer.data)
            else:
                reply = Reply(path.number, Status.failed, rcode=answer.rcode, reason="rcode_error")
            self.adapter._reply(path.client, reply)
        elif isinstance(path, ToBus):
            host = self.adapter.host
            if path.generation != host.generation:
                return  # the requester's transaction ended with the reset
            response = self._response(path.request, answer)
            host.station.send(ASYNC_PACKET, path.phy, response)

    def _response(self, request: Incoming, answer: Answer) -> bytes:
        to, label = request.source, request.tlabel
        me, rcode = LOCAL_BUS << 6 | self.node.phy_id, answer.rcode
        tcode, data = request.tcode, answer.data
        if tcode == TCode.read_quadlet_request:
            value = int.from_bytes(data[:4].ljust(4, b"\0"), "big")
            return encode_packet(
                QuadletReadResponse(
                    destination_id=to, tlabel=label, source_id=me, rcode=rcode, quadlet_data=value
                )
            )
        if tcode == TCode.read_block_request:
            return encode_packet(
                BlockReadResponse(
                    destination_id=to, tlabel=label, source_id=me, rcode=rcode, data=data
                )
            )
        if tcode == TCode.lock_request:
            return encode_packet(
                LockResponse(
                    destination_id=to,
                    tlabel=label,
                    source_id=me,
                    rcode=rcode,
                    extended_tcode=request.extended_tcode,
                    data=data,
                )
            )
        return encode_packet(
            WriteResponse(destination_id=to, tlabel=label, source_id=me, rcode=rcode)
        )

    def _ack(self, header: FrameHeader, tlabel: int, ack: AckCode, response: bytes = b"") -> None:
        frame = ACK_PAYLOAD.pack(ACK_BYTES[ack], tlabel, 0, header.sequence)
        self.adapter.host.station.send(ACK, header.sender_phy, frame + response)

    def _push(self, pushes: list[Push]) -> None:
        for push in pushes:
            client = push.owner
            if client in self.adapter.clients.values():
                reply = Reply(push.number, Status.ok, data=push.data)
                self.adapter._reply(client, reply)
