"""Comparing what a node answered with what the contract and the model expect.

:func:`difference` finds the first way an observed reply differs from the
expected one, looking only at what the transport shows and the model vouches
for; the trial turns differences into :class:`Violation` records, one
oracle each.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.crc import padded
from fw1394.engine import Reply
from fw1394.fuzz.contract import ack_name
from fw1394.fuzz.reference import Certainty
from fw1394.fuzz.target import Observed, Visibility
from fw1394.packets import AsyncPacket, PacketError, RCode, WriteResponse, name_of
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.nodeid import phy_of

#: The oracles, as the findings name them.
ORACLES = ("silence", "reply", "liveness", "state", "process", "interface", "side-effect")


@dataclass(frozen=True)
class Violation:
    """One broken promise: which oracle, a signature to deduplicate by, and the evidence."""

    oracle: str
    signature: str
    expected: str
    observed: str


def visible(reply: Reply, visibility: Visibility) -> Reply:
    """The part of ``reply`` the transport can show."""
    response = reply.response
    hidden_write = not visibility.write_responses and isinstance(response, WriteResponse)
    if hidden_write or _too_big(response, visibility.max_response):
        response = None
    ack = reply.ack if visibility.acks else None
    concatenated = reply.concatenated if visibility.tenure else False
    if ack is reply.ack and response is reply.response and concatenated == reply.concatenated:
        return reply
    return Reply(ack, response, concatenated and response is not None)


def wire_size(packet: AsyncPacket) -> int:
    """Bytes of ``packet`` on the wire, CRCs included."""
    data: bytes | None = getattr(packet, "data", None)
    size = 4 * packet.LAYOUT.sealed_header.count
    return size if data is None else size + len(padded(data)) + 4


def _too_big(response: AsyncPacket | None, limit: int) -> bool:
    data: bytes | None = getattr(response, "data", None)
    # Header-only packets are all far below any datagram limit.
    return data is not None and response is not None and wire_size(response) > limit


def is_silent(reply: Observed) -> bool:
    return reply.ack is None and reply.response is None


def describe(reply: Observed) -> str:
    """One line: the ack and a summary of the response."""
    parts = [ack_name(reply.ack)] if reply.ack is not None else []
    response = reply.response
    if isinstance(response, bytes):
        packet = _decoded(response)
        parts.append(_summary(packet) if packet is not None else f"bytes {response.hex()}")
    elif response is not None:
        parts.append(_summary(response))
        if reply.concatenated:
            parts[-1] += " (concatenated)"
    return " + ".join(parts) or "silence"


def difference(
    expected: Reply,
    observed: Observed,
    certainty: Certainty,
    visibility: Visibility,
    *,
    node_bits_only: bool,
) -> str | None:
    """The first field in which ``observed`` departs from ``expected``, or None.

    ``node_bits_only`` compares only the 6-bit node number of the response's
    source (for nodes that ignore bus IDs). Field names: ``ack``, ``tenure``,
    ``no-response``, ``unexpected-response``, ``response-undecodable``,
    ``response-crc`` and the response's header fields and ``data``.
    """
    if certainty >= Certainty.header:
        if visibility.acks and observed.ack != expected.ack:
            return "ack"
    elif visibility.acks and (observed.ack is None) != (expected.ack is None):
        return "ack"
    want, got = expected.response, observed.response
    if want is None:
        return None if got is None else "unexpected-response"
    if got is None:
        return "no-response"
    if isinstance(got, bytes):
        packet = _decoded(got)
        if packet is None:
            return "response-undecodable"
        if visibility.response_crcs and packet.problems:
            return "response-crc"
        got = packet
    tenure_known = certainty >= Certainty.header and visibility.tenure
    if tenure_known and observed.concatenated != expected.concatenated:
        return "tenure"
    return _field_difference(want, got, certainty, node_bits_only)


def _field_difference(
    want: AsyncPacket, got: AsyncPacket, certainty: Certainty, node_bits_only: bool
) -> str | None:
    if want == got:
        return None
    if type(want) is not type(got):
        return "tcode"
    names = ["tlabel", "destination_id"]
    if certainty >= Certainty.header:
        names += ["source_id", "rcode", "data_length", "extended_tcode"]
    if certainty >= Certainty.exact:
        names += ["quadlet_data", "data"]
    for name in names:
        a, b = getattr(want, name, None), getattr(got, name, None)
        if name == "source_id" and node_bits_only and a is not None and b is not None:
            a, b = phy_of(a), phy_of(b)
        if a != b:
            return name
    return None


def _decoded(raw: bytes) -> AsyncPacket | None:
    try:
        return decode_async(raw)
    except PacketError:
        return None


def _summary(packet: AsyncPacket) -> str:
    fields = [f"tlabel={getattr(packet, 'tlabel', '-')}"]
    for name in ("destination_id", "source_id"):
        value = getattr(packet, name, None)
        if value is not None:
            fields.append(f"{name.split('_')[0]}={value:#06x}")
    rcode = getattr(packet, "rcode", None)
    if rcode is not None:
        fields.append(name_of(RCode, rcode))
    quadlet = getattr(packet, "quadlet_data", None)
    if quadlet is not None:
        fields.append(f"data={quadlet:#010x}")
    data: bytes | None = getattr(packet, "data", None)
    if data is not None:
        shown = data[:16].hex() + ("..." if len(data) > 16 else "")
        fields.append(f"data_length={getattr(packet, 'data_length', len(data))} data={shown}")
    return f"{packet.kind}({', '.join(fields)})"
