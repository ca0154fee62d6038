"""What programs and a bus's host adapter say over its Unix socket (version 2).

``docs/host-adapter.md`` is the interface's reference: every field, byte
layouts, version negotiation and errors. In short: every message is one
frame, a big-endian u32 length and then a :data:`REQUEST` (client to
adapter) or a :data:`REPLY` (adapter to client). A connection starts with
``hello``, which agrees on a protocol version. A client may have many
requests outstanding; each carries a number of the client's choosing that
its reply repeats, and replies come in the order the transactions end.

Every request that names a node carries the bus generation its physical ID
was chosen in. Physical IDs are renumbered at every bus reset, so the
adapter runs a request only in that generation; one addressed in an earlier
generation is answered :attr:`Status.stale` and never sent (Linux's
firewire-cdev and libraw1394 do the same: ``EAGAIN``).
"""

from __future__ import annotations

import struct
from dataclasses import dataclass
from enum import IntEnum

from construct import (
    Float32b,
    FormatField,
    GreedyBytes,
    Int8sb,
    Int8ub,
    Int16ub,
    Int32ub,
    Int64ub,
    PascalString,
    Prefixed,
    StringEncoded,
    Struct,
)

from fw1394.errors import PacketError

#: Length prefix of every frame.
LENGTH = struct.Struct(">I")
#: No message is longer: the longest block plus its headers, with room to spare.
MAX_MESSAGE = 1 << 17
#: "No ack" and "no rcode" in a reply.
NONE = -1
#: The protocol version this module speaks, and every version an adapter accepts.
VERSION = 2
VERSIONS = frozenset({VERSION})
#: ``hello``'s data: the lowest and highest version the client speaks; the reply's
#: data: the version chosen (both big-endian u16).
HELLO = Struct("lowest" / Int16ub, "highest" / Int16ub)
CHOSEN = Struct("version" / Int16ub)
#: A ``stale`` reply's data: the generation the request was addressed in (big-endian u32).
STALE = struct.Struct(">I")


class Op(IntEnum):
    """The operations a bus adapter request asks for."""

    info = 0
    read = 1
    write = 2
    lock = 3
    send = 4
    hello = 5
    # The adapter's own node and its bus (fw1394.transport.host_adapter.services).
    watch = 6
    listen = 7
    unlisten = 8
    respond = 9
    cycle_time = 10
    config_rom = 11
    reset = 12
    iso_send = 13
    iso_listen = 14
    add_descriptor = 15
    remove_descriptor = 16


class Status(IntEnum):
    ok = 0
    #: The transaction ran and failed on the bus (``reason``, ``rcode``, ``detail``).
    failed = 1
    #: The adapter could not run it (bad request, not on the bus): ``detail`` says why.
    refused = 2
    #: The request was addressed in a generation that has ended (the reply's
    #: ``generation`` is the current one): it was not sent.
    stale = 3


REQUEST = Struct(
    "request" / Int32ub,  # the client's number, repeated in the reply
    "op" / Int8ub,  # Op
    "node" / Int8ub,  # physical ID (63: broadcast)
    "extended_tcode" / Int16ub,  # lock: which lock
    "generation" / Int32ub,  # the bus generation ``node`` was chosen in
    "offset" / Int64ub,  # 48-bit address offset
    "length" / Int32ub,  # block read: bytes
    "quadlet" / Int8ub,  # read/write: 1 for a quadlet transaction (write: the 4 data bytes)
    "wait" / Float32b,  # send: seconds to listen for an answer
    "argument" / Prefixed(Int32ub, GreedyBytes),  # lock argument
    "data" / Prefixed(Int32ub, GreedyBytes),  # write/lock data, or the packet to send
)

REPLY = Struct(
    "request" / Int32ub,
    "status" / Int8ub,  # Status
    "generation" / Int32ub,  # the bus generation when the transaction ended
    "phy" / Int8ub,  # the adapter's physical ID (0xFF: not on the bus)
    "ack" / Int8sb,  # send: ack code received, or NONE
    "rcode" / Int8sb,  # failed: the response's rcode, or NONE
    "outcome_unknown" / Int8ub,  # failed: 1 if a write or lock may have been performed
    "reason" / PascalString(Int8ub, "utf8"),  # failed: the engine's reason
    "detail" / PascalString(Int16ub, "utf8"),
    "data" / Prefixed(Int32ub, GreedyBytes),  # read data, old lock value, table, response
)

# The same layouts as struct formats, derived from the descriptions above: every
# transaction's request and reply goes through them, and construct's interpreter
# costs tens of microseconds a message (the adapter's main cost per transaction).


def _head(description: Struct) -> struct.Struct:
    """``description``'s fixed fields up to its first variable one, then that one's
    length prefix, as one struct format (the fields' own format characters)."""
    codes = []
    for field in (named.subcon for named in description.subcons):
        if isinstance(field, FormatField):
            codes.append(field.fmtstr[1:])
            continue
        prefixed = field.subcon if isinstance(field, StringEncoded) else field
        assert isinstance(prefixed, Prefixed), f"{field!r} is neither fixed nor prefixed"
        codes.append(prefixed.lengthfield.fmtstr[1:])
        break
    return struct.Struct(">" + "".join(codes))


#: REQUEST from ``request`` to ``wait``, then the argument's length.
_REQUEST_HEAD = _head(REQUEST)
#: REPLY from ``request`` to ``outcome_unknown``, then the reason's length.
_REPLY_HEAD = _head(REPLY)
_U8 = struct.Struct(">B")
_U16 = struct.Struct(">H")
_U32 = struct.Struct(">I")


@dataclass(frozen=True, slots=True)
class Request:
    request: int
    op: Op
    node: int = 0
    offset: int = 0
    length: int = 0
    quadlet: bool = False
    extended_tcode: int = 0
    wait: float = 0.0
    argument: bytes = b""
    data: bytes = b""
    generation: int = 0

    def pack(self) -> bytes:
        """The frame (length prefix and :data:`REQUEST`)."""
        argument, data = self.argument, self.data
        head = _REQUEST_HEAD.pack(
            self.request,
            self.op,
            self.node,
            self.extended_tcode,
            self.generation & 0xFFFFFFFF,
            self.offset,
            self.length,
            self.quadlet,
            self.wait,
            len(argument),
        )
        size = len(head) + len(argument) + 4 + len(data)
        return b"".join((LENGTH.pack(size), head, argument, _U32.pack(len(data)), data))


@dataclass(frozen=True, slots=True)
class Reply:
    request: int
    status: Status
    generation: int = 0
    phy: int = 0xFF
    ack: int = NONE
    rcode: int = NONE
    outcome_unknown: bool = False
    reason: str = ""
    detail: str = ""
    data: bytes = b""

    def pack(self, generation: int | None = None, phy: int | None = None) -> bytes:
        """The frame (length prefix and :data:`REPLY`); ``generation`` and ``phy``, when
        given, in place of the reply's own (the adapter's state as it sends)."""
        reason, detail, data = self.reason.encode(), self.detail[:0xFFFF].encode(), self.data
        head = _REPLY_HEAD.pack(
            self.request,
            self.status,
            (self.generation if generation is None else generation) & 0xFFFFFFFF,
            self.phy if phy is None else phy,
            self.ack,
            self.rcode,
            self.outcome_unknown,
            len(reason),
        )
        parts = (head, reason, _U16.pack(len(detail)), detail, _U32.pack(len(data)), data)
        body = b"".join(parts)
        return LENGTH.pack(len(body)) + body


#: An ``ok`` reply with data only (a read's or a write's end), whole: the length
#: prefix, :data:`REPLY`'s head, the empty reason and detail, the data's length.
_OK_REPLY = struct.Struct(">I" + _REPLY_HEAD.format[1:] + "HI")
_OK_BODY = _OK_REPLY.size - LENGTH.size


def ok_reply(request: int, generation: int, phy: int, data: bytes) -> bytes:
    """The frame of ``Reply(request, Status.ok, data=data).pack(generation, phy)`` in
    one step, as the adapter sends it for every read or write that ends well."""
    size = len(data)
    head = _OK_REPLY.pack(
        _OK_BODY + size, request, Status.ok, generation & 0xFFFFFFFF, phy, NONE, NONE, 0, 0, 0, size
    )
    return head + data if size else head


class ProtocolError(PacketError):
    """Bytes that are not a message of this protocol."""


def _prefixed(body: bytes, at: int, prefix: struct.Struct) -> tuple[bytes, int]:
    """The bytes whose length ``prefix`` gives at ``at``, and where they end."""
    (size,) = prefix.unpack_from(body, at)
    start = at + prefix.size
    end = start + size
    if end > len(body):
        raise ProtocolError(f"{size} bytes announced at byte {start}, {len(body) - start} left")
    return body[start:end], end


def parse_request(body: bytes) -> Request:
    try:
        (number, op, node, extended_tcode, generation, offset, length, quadlet, wait, _) = (
            _REQUEST_HEAD.unpack_from(body)
        )
        argument, at = _prefixed(body, _REQUEST_HEAD.size - 4, _U32)
        data, _ = _prefixed(body, at, _U32)
        operation = Op(op)
    except (struct.error, ValueError) as error:  # ProtocolError is a ValueError too
        raise ProtocolError(f"not an adapter request: {error}") from None
    return Request(
        number,
        operation,
        node,
        offset,
        length,
        bool(quadlet),
        extended_tcode,
        wait,
        argument,
        data,
        generation,
    )


#: A whole request frame's length prefix and :data:`REQUEST`'s head, as one struct.
_REQUEST_FRAME = struct.Struct(">I" + _REQUEST_HEAD.format[1:])
_FRAME_DATA_AT = _REQUEST_FRAME.size + _U32.size
#: A read's or a write's fields, as :func:`one_transfer` finds them: request number,
#: op, node, generation, offset, length, quadlet, data.
Transfer = tuple[int, int, int, int, int, int, int, bytes]


def one_transfer(frame: bytes) -> Transfer | None:
    """The fields of ``frame`` if it is exactly one whole read or write request
    (length prefix included) with no lock argument; None for anything else, which
    the general way (:class:`FrameBuffer`, :func:`parse_request`) takes instead.

    Every blocking read and write a program makes comes alone in one receive, so
    the adapter reads them without building a :class:`Request`.
    """
    if len(frame) < _FRAME_DATA_AT:
        return None
    (size, number, op, node, _, generation, offset, length, quadlet, _, argument) = (
        _REQUEST_FRAME.unpack_from(frame)
    )
    if (op != Op.read and op != Op.write) or argument or size != len(frame) - LENGTH.size:
        return None
    (data_size,) = _U32.unpack_from(frame, _REQUEST_FRAME.size)
    if _FRAME_DATA_AT + data_size != len(frame):
        return None
    return number, op, node, generation, offset, length, quadlet, frame[_FRAME_DATA_AT:]


def hello(request: int, lowest: int = VERSION, highest: int = VERSION) -> Request:
    """The first request of a connection: the versions the client speaks."""
    return Request(request, Op.hello, data=HELLO.build({"lowest": lowest, "highest": highest}))


def choose_version(request: Request) -> int | None:
    """The version an adapter speaks with the sender of ``hello``; None: none in common."""
    try:
        offered = HELLO.parse(request.data)
    except Exception:  # construct raises many kinds; a short hello offers nothing
        return None
    common = [v for v in VERSIONS if offered.lowest <= v <= offered.highest]
    return max(common, default=None)


def parse_reply(body: bytes) -> Reply:
    try:
        (number, status, generation, phy, ack, rcode, outcome_unknown, _) = _REPLY_HEAD.unpack_from(
            body
        )
        reason, at = _prefixed(body, _REPLY_HEAD.size - 1, _U8)
        detail, at = _prefixed(body, at, _U16)
        data, _ = _prefixed(body, at, _U32)
        return Reply(
            number,
            Status(status),
            generation,
            phy,
            ack,
            rcode,
            bool(outcome_unknown),
            reason.decode(),
            detail.decode(),
            data,
        )
    except (struct.error, ValueError) as error:  # UnicodeDecodeError is a ValueError
        raise ProtocolError(f"not an adapter reply: {error}") from None


class FrameBuffer:
    """Bytes from a stream socket in, whole message bodies out."""

    def __init__(self) -> None:
        self._buffer = bytearray()

    @property
    def empty(self) -> bool:
        """Whether no part of a message waits for the rest."""
        return not self._buffer

    def feed(self, data: bytes) -> list[bytes]:
        buffer = self._buffer
        buffer += data
        bodies = []
        while len(buffer) >= LENGTH.size:
            (size,) = LENGTH.unpack_from(buffer)
            if size > MAX_MESSAGE:
                raise ProtocolError(f"a message of {size} bytes is longer than {MAX_MESSAGE}")
            if len(buffer) < LENGTH.size + size:
                break
            bodies.append(bytes(buffer[LENGTH.size : LENGTH.size + size]))
            del buffer[: LENGTH.size + size]
        return bodies
