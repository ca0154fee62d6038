"""The responder's common turn on flat bytes: request in, ack frame payload out.

A node spends most of a quadlet read making objects: the request packet, the
response packet, the :class:`~fw1394.engine.responder.Reply`. The common case
needs none of them. :class:`FastResponder` serves a sound request (CRCs and
length right) addressed to its node, of a kind its policy answers at once
(reads concatenated, writes unified or concatenated), with one function per
request kind generated from the packet layouts (:mod:`fw1394.packets.layouts`)
and the answers of :mod:`fw1394.engine.table`. The result is the payload of the
ack frame: the ack, and behind it the response's wire bytes.

Everything else is declined before anything happens (``None``) and left to the
:class:`~fw1394.engine.responder.Responder`, which stays the reference: damaged
packets, broadcasts, other nodes' packets, locks, split delivery, injected busy.
A request the address space refuses has been served already when the refusal
comes, so its answer is the reference's own :class:`Reply` for it (built by
:meth:`Responder.refusal`). Tests hold both paths equal with hypothesis.
"""

from __future__ import annotations

import struct
from collections.abc import Callable, Mapping
from dataclasses import MISSING, fields
from typing import Any

from fw1394.crc import crc32
from fw1394.engine.responder import Reply, Responder
from fw1394.engine.space import TICKS_PER_SECOND, SpaceError
from fw1394.engine.table import ANSWERS, Answer, Delivery, Outcome
from fw1394.packets import (
    AsyncPacket,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    QuadletWriteRequest,
    WriteResponse,
)
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.codegen import compile_function
from fw1394.packets.fast import block_crc, builder, data_block_source, decode_sound, substitute
from fw1394.packets.frame import ACK_FRAME_FORMAT
from fw1394.packets.layouts import TCODE_BYTE, TCODE_SHIFT
from fw1394.packets.nodeid import LOCAL_BUS

#: The ack frame payload's result: bytes to send, the reference's reply for a
#: refusal, or None when the reference must serve the packet from the start.
FastReply = bytes | Reply | None
Handler = Callable[[bytes, int, float], FastReply]

#: request class -> (response class or None for a write, the space method, is a read).
_KINDS: dict[type[AsyncPacket], tuple[type[AsyncPacket], str, bool]] = {
    QuadletReadRequest: (QuadletReadResponse, "read_quadlet", True),
    BlockReadRequest: (BlockReadResponse, "read_block", True),
    QuadletWriteRequest: (WriteResponse, "write_quadlet", False),
    BlockWriteRequest: (WriteResponse, "write_block", False),
}
_IMMEDIATE = (Delivery.concatenated, Delivery.unified)
_QUADLET = struct.Struct(">I")


class FastResponder:
    """The common turn of ``responder``; see the module docstring."""

    def __init__(self, responder: Responder) -> None:
        self.responder = responder
        policy = responder.policy
        self._handlers: dict[int, Handler] = {}
        for request, (response, method, read) in _KINDS.items():
            delivery = Delivery(policy.read_mode if read else policy.write_mode)
            if delivery not in _IMMEDIATE:
                continue
            done = ANSWERS[delivery][Outcome.done]
            tcode = int(request.LAYOUT.tcode)
            self._handlers[tcode] = _handler(responder, request, response, method, done, read)

    @property
    def handlers(self) -> Mapping[int, Handler]:
        """Request tcode -> its turn (:meth:`serve` without the tcode lookup)."""
        return self._handlers

    @property
    def kinds(self) -> frozenset[int]:
        """Request tcodes this node serves on the fast path."""
        return frozenset(self._handlers)

    def serve(self, raw: bytes, sequence: int, now: float) -> FastReply:
        """The ack frame payload for request ``raw`` that came in frame ``sequence``.

        ``now`` is the responder's time (seconds from its epoch). None: nothing was
        done, serve ``raw`` the reference way.
        """
        if len(raw) <= TCODE_BYTE:
            return None
        handler = self._handlers.get(raw[TCODE_BYTE] >> TCODE_SHIFT)
        return None if handler is None else handler(raw, sequence, now)


def _defaults(cls: type[AsyncPacket], given: set[str]) -> dict[str, Any]:
    """Default values of the header fields of ``cls`` that are not ``given``."""
    out = {}
    for f in fields(cls):
        if f.name in given or f.default is MISSING:
            continue
        out[f.name] = f.default
    return out


def _handler(
    responder: Responder,
    request: type[AsyncPacket],
    response: type[AsyncPacket],
    method: str,
    done: Answer,
    read: bool,
) -> Handler:
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
        "LOCAL_BUS": LOCAL_BUS,
        "ignore_bus": responder.policy.ignore_bus_id,
        "refusal": responder.refusal,
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
        # Broadcasts and other nodes' packets are the reference's.
        "    if destination_id & 0x3F != me & 0x3F or destination_id & 0x3F == 0x3F:",
        "        return None",
        "    bus = destination_id >> 6",
        "    if not (bus == LOCAL_BUS or ignore_bus or bus == me >> 6):",
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
        return _compile(lines, namespace)
    lines += _response_lines(response, namespace, method)
    return _compile(lines, namespace)


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


def _compile(lines: list[str], namespace: dict[str, Any]) -> Handler:
    handler: Handler = compile_function(
        lines, namespace, "serve", origin="fw1394.engine.fast_responder serve"
    )
    return handler
