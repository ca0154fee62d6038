"""The node side: turn a received request into silence, an ack, or an ack and a response.

The path through a request follows :mod:`fw1394.engine.table` (screens in order,
then one answer by outcome); this module only does what those rows say. It owns
no socket and no clock: raw bytes and the time come in, a :class:`Reply` (or the
ack frame's bytes) goes out.

:meth:`Responder.serve` is the call for a transport. Its common case, a sound
request addressed to this node of a kind the policy answers at once (reads
concatenated, writes unified or concatenated), runs one function per request
kind, generated from the packet layouts (:mod:`fw1394.packets.layouts`) and the
rows of the table, that performs the request and packs the ack frame's payload
(the ack, and behind it the response's wire bytes) without making a packet.
Everything else it declines before anything has happened, and
:meth:`Responder.receive` answers it by walking the table: damaged packets,
broadcasts, other nodes' packets, locks, split delivery, injected busy. A
request the space refuses has been performed already when the refusal comes,
so its answer is the table's :class:`Reply` for that refusal. Tests hold
``serve`` equal to ``receive`` with hypothesis.
"""

from __future__ import annotations

import struct
from collections.abc import Callable
from dataclasses import MISSING, fields
from typing import Any, NamedTuple

from fw1394.crc import crc32
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
from fw1394.engine.table import (
    ANSWERS,
    SCREENS,
    Addressee,
    Answer,
    Delivery,
    Outcome,
    Screen,
    addressee,
)
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
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.codegen import compile_function
from fw1394.packets.fast import block_crc, builder, data_block_source, decode_sound, substitute
from fw1394.packets.frame import ACK_FRAME_FORMAT
from fw1394.packets.layouts import TCODE_BYTE, TCODE_SHIFT

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


#: A common turn's result: the ack frame's payload, the table's reply to a refused
#: request, or None: nothing was done, the table decides from the start.
_Turn = Callable[[bytes, int, float], "bytes | Reply | None"]


def _reply(answer: Answer) -> Reply:
    return Reply(answer.ack, None, False)


_SILENT = _reply(SCREENS[Screen.undecodable])
_THIS_NODE, _BROADCAST, _OTHER = Addressee.this_node, Addressee.broadcast, Addressee.other
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
        # request tcode -> its common turn. A subclass that changes the decisions
        # (planted defects) has its own rules: the table's walk serves it all.
        self._turns: dict[int, _Turn] = (
            _common_turns(self) if type(self).receive_packet is Responder.receive_packet else {}
        )

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
    def serve(self, raw: bytes, sequence: int, now: float) -> bytes | Reply:
        """The answer to the packet ``raw`` that came in frame ``sequence`` at ``now``.

        In the common case (see the module docstring) the payload of the ack frame
        to send back: the ack naming frame ``sequence``, and the response behind it
        when there is one. Otherwise the :class:`Reply` of :meth:`receive`.
        """
        if len(raw) > TCODE_BYTE:
            turn = self._turns.get(raw[TCODE_BYTE] >> TCODE_SHIFT)
            if turn is not None:
                answer = turn(raw, sequence, now)
                if answer is not None:
                    return answer
        return self.receive(raw, now)

    @property
    def common_kinds(self) -> frozenset[int]:
        """Request tcodes :meth:`serve` answers without :meth:`receive` when all is well."""
        return frozenset(self._turns)

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
        whom = addressee(packet.destination_id, self._node_id, self._ignore_bus_id)
        if whom is _OTHER:
            return _SILENT  # Screen.not_addressed
        broadcast = whom is _BROADCAST
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
    def _refusal(self, request: AsyncPacket | None, error: SpaceError, *, read: bool) -> Reply:
        """The reply to ``request`` (served already) when its space raised ``error``.

        ``read``: a read or lock (answered by the read policy), else a write. For a
        common turn, which performed the request itself.
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


# -- the common turns, generated --------------------------------------------------------
#: request class -> (response class, the space method, is a read).
_KINDS: dict[type[AsyncPacket], tuple[type[AsyncPacket], str, bool]] = {
    QuadletReadRequest: (QuadletReadResponse, "read_quadlet", True),
    BlockReadRequest: (BlockReadResponse, "read_block", True),
    QuadletWriteRequest: (WriteResponse, "write_quadlet", False),
    BlockWriteRequest: (WriteResponse, "write_block", False),
}
#: Deliveries whose whole answer is one ack frame.
_IMMEDIATE = (Delivery.concatenated, Delivery.unified)
_QUADLET = struct.Struct(">I")


def _common_turns(responder: Responder) -> dict[int, _Turn]:
    """Request tcode -> its common turn, for each kind the policy answers at once."""
    policy = responder.policy
    turns: dict[int, _Turn] = {}
    for request, (response, method, read) in _KINDS.items():
        delivery = Delivery(policy.read_mode if read else policy.write_mode)
        if delivery not in _IMMEDIATE:
            continue
        done = ANSWERS[delivery][Outcome.done]
        turns[int(request.LAYOUT.tcode)] = _turn(responder, request, response, method, done, read)
    return turns


def _defaults(cls: type[AsyncPacket], given: set[str]) -> dict[str, Any]:
    """Default values of the header fields of ``cls`` that are not ``given``."""
    out = {}
    for f in fields(cls):
        if f.name in given or f.default is MISSING:
            continue
        out[f.name] = f.default
    return out


def _turn(
    responder: Responder,
    request: type[AsyncPacket],
    response: type[AsyncPacket],
    method: str,
    done: Answer,
    read: bool,
) -> _Turn:
    """The common turn of ``responder`` for ``request`` packets, answered by ``done``."""
    layout = request.LAYOUT
    sealed = layout.sealed_header
    size = 4 * sealed.count
    expressions = sealed.field_expressions()
    assert done.ack is not None
    namespace: dict[str, Any] = {
        "responder": responder,
        "space": responder.space,
        "operation": getattr(responder.space, method),
        "unpack_from": sealed.format.unpack_from,
        "crc": crc32,
        "block_crc": block_crc,
        "from_bytes": int.from_bytes,
        "pack_ack": ACK_FRAME_FORMAT.pack,
        "ack_byte": ACK_BYTES[done.ack],
        "ack_code": done.ack,
        "concatenated": done.concatenated,
        "source_expression": expressions["source_id"],
        "SpaceError": SpaceError,
        "TICKS": TICKS_PER_SECOND,
        "addressee": addressee,
        "THIS_NODE": Addressee.this_node,
        "ignore_bus": responder.policy.ignore_bus_id,
        "refusal": responder._refusal,
        "decode": decode_sound,
    }
    quadlets = ", ".join(f"q{i}" for i in range(sealed.count))
    lines = [
        "def serve(raw, sequence, now):",
        f"    if len(raw) {'<' if layout.has_data else '!='} {size}:",
        "        return None",
        f"    {quadlets}{',' if sealed.count == 1 else ''} = unpack_from(raw)",
        f"    if crc(raw[:{size - 4}]) != {expressions['header_crc']}:",
        "        return None",
        f"    destination_id = {expressions['destination_id']}",
        "    me = responder._node_id",
        # The table's address screen: broadcasts and other nodes' packets go its way.
        "    if addressee(destination_id, me, ignore_bus) is not THIS_NODE:",
        "        return None",
        "    if responder._busy_left:",
        "        return None",
    ]
    if layout.has_data:
        lines += data_block_source(size, expressions["data_length"])
    lines += [
        # The board's clock reads the time the request came, as in the reference.
        "    ticks = int(now * TICKS)",
        "    if ticks > responder._ticks:",
        "        responder._ticks = ticks",
        "        space.set_time(ticks)",
        f"    tlabel = {expressions['tlabel']}",
        f"    offset = {expressions['offset']}",
    ]
    argument = {
        "read_quadlet": "offset",
        "read_block": "offset, {data_length}",
        "write_quadlet": "offset, {quadlet_data}",
        "write_block": "offset, data",
    }[method].format_map(expressions)
    result = "value = " if read else ""
    lines += [
        "    try:",
        f"        {result}operation({argument})",
        "    except SpaceError as error:",
        f"        return refusal(decode(raw), error, read={read})",
        "    ack = pack_ack(ack_byte, tlabel, 0, sequence)",
    ]
    if done.rcode is None:  # a unified write: the ack is the whole answer
        lines.append("    return ack")
        return _compile(lines, namespace, request)
    lines += _response_lines(response, namespace, method)
    return _compile(lines, namespace, request)


def _response_lines(response: type[AsyncPacket], namespace: dict[str, Any], read: str) -> list[str]:
    """Lines packing the response behind ``ack``; ``read``: the space method it answers."""
    header = response.LAYOUT.header
    given = {"destination_id", "tlabel", "source_id", "quadlet_data", "data", "data_length"}
    values = {
        name: repr(int(value))
        for name, value in _defaults(response, given).items()
        if name in header.names
    }
    values.update(destination_id="requester", tlabel="tlabel", source_id="me")
    values["tcode"] = repr(int(response.LAYOUT.tcode))
    namespace["pack_header"] = header.format.pack
    namespace["quadlet"] = _QUADLET.pack
    # What the reference builds: for values the packer does not take as they are.
    built = {"read_quadlet": "quadlet_data", "read_block": "data"}.get(read)
    if built is not None:
        namespace["build"] = builder(response, "destination_id", "tlabel", "source_id", built)
    namespace["Reply"] = Reply
    lines = [f"    requester = {namespace['source_expression']}"]
    if read == "read_quadlet":
        values["quadlet_data"] = "value"
        lines += [
            "    if value.__class__ is not int or not 0 <= value <= 0xFFFFFFFF:",
            "        return Reply(ack_code, build(requester, tlabel, me, value), concatenated)",
        ]
    elif read == "read_block":
        values["data_length"] = "length"
        lines += [
            "    length = len(value)",
            "    if value.__class__ is not bytes or length > 0xFFFF:",
            "        return Reply(ack_code, build(requester, tlabel, me, value), concatenated)",
        ]
    quadlets = ", ".join(
        substitute(expression, values) for expression in header.quadlet_expressions()
    )
    lines.append(f"    head = pack_header({quadlets})")
    if read == "read_block":
        lines += [
            "    if length & 3:",
            "        value = value + bytes(4 - (length & 3))",
            "    crcs = quadlet(crc(head)), quadlet(block_crc(value))",
            "    return b''.join((ack, head, crcs[0], value, crcs[1]))",
        ]
    else:
        lines.append("    return b''.join((ack, head, quadlet(crc(head))))")
    return lines


def _compile(lines: list[str], namespace: dict[str, Any], request: type[AsyncPacket]) -> _Turn:
    origin = f"fw1394.engine.responder serve {request.__name__}"
    turn: _Turn = compile_function(lines, namespace, "serve", origin=origin)
    return turn
