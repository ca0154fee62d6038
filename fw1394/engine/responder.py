"""The node side: turn a received request into silence, an ack, or an ack and a response.

The path through a request follows :mod:`fw1394.engine.table` (screens in order,
then one answer by outcome); this module only does what those rows say. It owns
no socket and no clock: raw bytes and the time come in, a :class:`Reply` goes out.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import NamedTuple

from fw1394.engine.locks import perform_lock
from fw1394.engine.policy import IEEE1394_NODE, ResponderPolicy
from fw1394.engine.space import (
    TICKS_PER_SECOND,
    AddressError,
    AddressSpace,
    BusyError,
    DataError,
    SpaceError,
    TypeError1394,
)
from fw1394.engine.table import ANSWERS, SCREENS, Answer, Delivery, Outcome, Screen
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    LockRequest,
    LockResponse,
    PacketError,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    RCode,
    Request,
    WriteResponse,
)
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.fast import builder, decode_sound
from fw1394.packets.nodeid import BROADCAST_PHY, LOCAL_BUS, bus_of, phy_of

# A response per request: built straight into the frozen dataclass's slots.
_ROUTE = ("destination_id", "tlabel", "source_id")
_new_read_quadlet = builder(QuadletReadResponse, *_ROUTE, "quadlet_data")
_new_read_block = builder(BlockReadResponse, *_ROUTE, "data")
_new_lock = builder(LockResponse, *_ROUTE, "extended_tcode", "data")
_new_write = builder(WriteResponse, *_ROUTE)


class Reply(NamedTuple):
    """What a node sends back for one received packet."""

    #: The ack code; ``None`` is silence.
    ack: int | None
    #: The response packet, if any (CRCs are left for the encoder to compute).
    response: AsyncPacket | None
    #: ``True``: send the response right after the ack, in the same bus tenure.
    #: ``False`` with a response: a split transaction, the response is a
    #: subaction of its own that the requester acks.
    concatenated: bool


def _reply(answer: Answer) -> Reply:
    return Reply(answer.ack, None, False)


_SILENT = _reply(SCREENS[Screen.undecodable])
_ACK_DATA_ERROR = _reply(SCREENS[Screen.damaged_acked])
_ACK_TYPE_ERROR = _reply(SCREENS[Screen.unsupported_acked])

_WRITES = (QuadletWriteRequest, BlockWriteRequest)
_REQUEST_TYPES: frozenset[type[AsyncPacket]] = frozenset(
    {QuadletReadRequest, BlockReadRequest, LockRequest, *_WRITES}
)


def _outcome(error: SpaceError, policy: ResponderPolicy) -> Outcome:
    if isinstance(error, AddressError):
        return (
            Outcome.address_error_ack
            if policy.address_error == "ack"
            else Outcome.address_error_rcode
        )
    if isinstance(error, DataError):
        return Outcome.data_error
    if isinstance(error, TypeError1394):
        return Outcome.type_error
    if isinstance(error, BusyError):
        return Outcome.busy
    return Outcome.conflict_error


def decode_received(raw: bytes) -> tuple[AsyncPacket | None, bool]:
    """Decode received wire bytes: (packet, whether it has problems), or (None, True).

    A sound packet costs one strict decode; only a damaged one is decoded again,
    leniently, so that its ``problems`` can be examined.
    """
    packet = decode_sound(raw)
    if packet is not None:
        return packet, False
    try:
        return decode_async(raw), True
    except PacketError:
        return None, True


class Responder:
    """Answers the requests addressed to one node from its address space.

    Before serving a request the responder advances the space's clock to ``now``
    (in 49.152 MHz ticks), so a board stamps its data with the time the request
    arrived.
    """

    def __init__(
        self,
        node_id: int,
        space: AddressSpace,
        policy: ResponderPolicy = IEEE1394_NODE,
        *,
        generation: int = 0,
    ) -> None:
        self._node_id = node_id
        self._space = space
        self._policy = policy
        self._ignore_bus_id = policy.ignore_bus_id
        self._generation = generation
        self._ticks = -1
        self._busy_left = 0
        self._busy_reply = _reply(SCREENS[Screen.injected_busy])
        self._read_answers = ANSWERS[Delivery(policy.read_mode)]
        self._write_answers = ANSWERS[Delivery(policy.write_mode)]
        self._read_done = self._read_answers[Outcome.done]
        write_done = self._write_answers[Outcome.done]
        # A unified write's success is always the same reply: made once.
        self._write_done = _reply(write_done) if write_done.rcode is None else None
        self._serve: dict[type[AsyncPacket], Callable[[Request], Reply]] = {
            QuadletReadRequest: self._read_quadlet,
            BlockReadRequest: self._read_block,
            QuadletWriteRequest: self._write_quadlet,
            BlockWriteRequest: self._write_block,
        }
        if policy.locks:
            self._serve[LockRequest] = self._lock

    # -- state -------------------------------------------------------------------------
    @property
    def node_id(self) -> int:
        return self._node_id

    @property
    def generation(self) -> int:
        return self._generation

    @property
    def policy(self) -> ResponderPolicy:
        return self._policy

    @property
    def space(self) -> AddressSpace:
        return self._space

    def inject_busy(self, count: int, ack: int = AckCode.ack_busy_X) -> None:
        """Refuse the next ``count`` requests to this node with ``ack`` (ack_busy_X, _A or _B).

        Only requests that would otherwise be served count: broadcasts, damaged and
        unsupported packets are answered as usual.
        """
        if ack not in (AckCode.ack_busy_X, AckCode.ack_busy_A, AckCode.ack_busy_B):
            raise ValueError(f"{ack!r} is not a busy ack code")
        self._busy_left = count
        self._busy_reply = Reply(ack, None, False)

    def bus_reset(self, *, node_id: int, generation: int) -> None:
        """Take the physical ID the node got in the new bus generation."""
        self._node_id = node_id
        self._generation = generation

    def advance_clock(self, now: float) -> None:
        """Bring the space's clock to ``now`` (s), as receiving a request at ``now`` does.

        For a transport that performs a request on the space itself.
        """
        ticks = int(now * TICKS_PER_SECOND)
        if ticks > self._ticks:
            self._ticks = ticks
            self._space.set_time(ticks)

    # -- receiving ---------------------------------------------------------------------
    def receive(self, raw: bytes, now: float) -> Reply:
        """The reply to the packet ``raw`` (wire bytes with CRCs) received at ``now``."""
        packet, damaged = decode_received(raw)
        if packet is None:
            return _SILENT  # Screen.undecodable
        return self.receive_packet(packet, now, damaged=damaged)

    def receive_packet(self, packet: AsyncPacket, now: float, *, damaged: bool = False) -> Reply:
        """The reply to a packet already decoded; ``damaged``: it has ``problems``.

        For a transport that decodes once and hands the packet to several nodes.
        """
        self.advance_clock(now)
        kind = type(packet)
        if kind not in _REQUEST_TYPES:
            return _SILENT  # Screen.not_a_request
        assert isinstance(packet, Request)
        destination = packet.destination_id
        node = phy_of(destination)
        broadcast = node == BROADCAST_PHY
        if not (broadcast or node == phy_of(self._node_id)):
            return _SILENT  # Screen.not_addressed
        bus = bus_of(destination)
        if not (bus == LOCAL_BUS or self._ignore_bus_id or bus == bus_of(self._node_id)):
            return _SILENT  # Screen.not_addressed
        serve = self._serve.get(kind)
        if serve is None and (broadcast or self._policy.unsupported_tcode == "silent"):
            return _SILENT  # Screen.unsupported_silent
        if damaged and self._still_damaged(packet):
            return self._damaged(packet, broadcast)
        if broadcast:
            if isinstance(packet, _WRITES):
                self._perform_write(packet)
            return _SILENT  # Screen.broadcast_write / Screen.broadcast_other
        if serve is None:
            return _ACK_TYPE_ERROR  # Screen.unsupported_acked
        if self._busy_left:
            self._busy_left -= 1
            return self._busy_reply  # Screen.injected_busy
        return serve(packet)

    def _still_damaged(self, packet: AsyncPacket) -> bool:
        # A link that never compares a block write's header CRC sees only the rest.
        if isinstance(packet, BlockWriteRequest) and not self._policy.check_block_write_header_crc:
            return any(problem.field != "header_crc" for problem in packet.problems)
        return True

    def _damaged(self, packet: Request, broadcast: bool) -> Reply:
        policy = self._policy
        if policy.bad_crc == "drop":
            return _SILENT  # Screen.damaged_dropped
        if policy.drop_bad_header_crc and packet.header_crc_ok is False:
            return _SILENT  # Screen.damaged_dropped
        if policy.write_despite_bad_crc and isinstance(packet, _WRITES):
            self._perform_write(packet)
        return _SILENT if broadcast else _ACK_DATA_ERROR  # damaged_broadcast / damaged_acked

    def _perform_write(self, packet: QuadletWriteRequest | BlockWriteRequest) -> None:
        # A write nobody acks (broadcast, or damaged) cannot report a refusal.
        try:
            if isinstance(packet, QuadletWriteRequest):
                self._space.write_quadlet(packet.offset, packet.quadlet_data)
            else:
                self._space.write_block(packet.offset, packet.data)
        except SpaceError:
            pass

    # -- serving -----------------------------------------------------------------------
    def refusal(self, request: AsyncPacket | None, error: SpaceError, *, read: bool) -> Reply:
        """The reply to ``request`` (served already) when its space raised ``error``.

        ``read``: a read or lock (answered by the read policy), else a write. For a
        fast path that performed the request itself.
        """
        assert isinstance(request, Request)
        answers = self._read_answers if read else self._write_answers
        return self._refuse(request, answers, error)

    def _refuse(self, request: Request, answers: dict[Outcome, Answer], error: SpaceError) -> Reply:
        answer = answers[_outcome(error, self._policy)]
        if answer.rcode is None:
            return _reply(answer)
        return Reply(answer.ack, self._error_response(request, answer.rcode), answer.concatenated)

    def _error_response(self, request: Request, rcode: RCode) -> AsyncPacket:
        # An error response carries no data (data_length 0 for block and lock).
        to, label, me = request.source_id, request.tlabel, self._node_id
        if isinstance(request, QuadletReadRequest):
            return QuadletReadResponse(destination_id=to, tlabel=label, source_id=me, rcode=rcode)
        if isinstance(request, BlockReadRequest):
            return BlockReadResponse(destination_id=to, tlabel=label, source_id=me, rcode=rcode)
        if isinstance(request, LockRequest):
            return LockResponse(
                destination_id=to,
                tlabel=label,
                source_id=me,
                rcode=rcode,
                extended_tcode=request.extended_tcode,
            )
        return WriteResponse(destination_id=to, tlabel=label, source_id=me, rcode=rcode)

    def _read_quadlet(self, request: Request) -> Reply:
        assert isinstance(request, QuadletReadRequest)
        try:
            value = self._space.read_quadlet(request.offset)
        except SpaceError as error:
            return self._refuse(request, self._read_answers, error)
        response = _new_read_quadlet(request.source_id, request.tlabel, self._node_id, value)
        return Reply(self._read_done.ack, response, self._read_done.concatenated)

    def _read_block(self, request: Request) -> Reply:
        assert isinstance(request, BlockReadRequest)
        try:
            data = self._space.read_block(request.offset, request.data_length)
        except SpaceError as error:
            return self._refuse(request, self._read_answers, error)
        response = _new_read_block(request.source_id, request.tlabel, self._node_id, data)
        return Reply(self._read_done.ack, response, self._read_done.concatenated)

    def _lock(self, request: Request) -> Reply:
        # Locks are delivered like reads: the old value comes back in a response.
        assert isinstance(request, LockRequest)
        try:
            old = perform_lock(self._space, request)
        except SpaceError as error:
            return self._refuse(request, self._read_answers, error)
        to, label, code = request.source_id, request.tlabel, request.extended_tcode
        response = _new_lock(to, label, self._node_id, code, old)
        return Reply(self._read_done.ack, response, self._read_done.concatenated)

    def _write_quadlet(self, request: Request) -> Reply:
        assert isinstance(request, QuadletWriteRequest)
        try:
            self._space.write_quadlet(request.offset, request.quadlet_data)
        except SpaceError as error:
            return self._refuse(request, self._write_answers, error)
        return self._write_success(request)

    def _write_block(self, request: Request) -> Reply:
        assert isinstance(request, BlockWriteRequest)
        try:
            self._space.write_block(request.offset, request.data)
        except SpaceError as error:
            return self._refuse(request, self._write_answers, error)
        return self._write_success(request)

    def _write_success(self, request: Request) -> Reply:
        if self._write_done is not None:
            return self._write_done
        answer = self._write_answers[Outcome.done]
        response = _new_write(request.source_id, request.tlabel, self._node_id)
        return Reply(answer.ack, response, answer.concatenated)
