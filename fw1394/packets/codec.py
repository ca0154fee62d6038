"""One entry point for every kind of packet: :func:`decode` and :func:`encode`."""

from __future__ import annotations

from typing import Literal

from fw1394.packets.ack import Ack, decode_ack, encode_ack
from fw1394.packets.asynchronous import AsyncPacket, decode_async, encode_async
from fw1394.packets.errors import PacketError
from fw1394.packets.phy import PhyPacket, decode_phy, encode_phy

Packet = AsyncPacket | PhyPacket | Ack
Kind = Literal["auto", "async", "phy", "ack"]


def looks_like_phy(raw: bytes) -> bool:
    """Eight bytes whose second quadlet is the complement of the first."""
    return len(raw) == 8 and int.from_bytes(raw[:4], "big") ^ int.from_bytes(raw[4:], "big") == (
        0xFFFFFFFF
    )


def decode(raw: bytes, *, crc: bool = True, strict: bool = True, kind: Kind = "auto") -> Packet:
    """Decode ``raw`` into a packet.

    ``kind="auto"`` takes one byte as an ack, eight bytes whose halves are
    complements as a PHY packet, and anything else as an asynchronous packet.
    ``crc=False`` expects no CRC quadlets (and no PHY check quadlet), as the Linux
    kernel prints headers. With ``strict=True`` any problem (bad CRC, length
    disagreements, trailing bytes) raises :class:`PacketError`; with
    ``strict=False`` the packet is returned and its ``problems`` say what is wrong.
    """
    if kind == "auto":
        kind = "ack" if len(raw) == 1 else "phy" if looks_like_phy(raw) else "async"
    if kind == "async":
        return decode_async(raw, crc=crc, strict=strict)
    packet: Packet = decode_ack(raw) if kind == "ack" else decode_phy(raw, inverse=crc)
    if strict and packet.problems:
        raise packet.problems[0]
    return packet


def encode(packet: Packet, *, crc: bool = True) -> bytes:
    """Wire bytes of ``packet`` (see :func:`decode` for ``crc``)."""
    if isinstance(packet, Ack):
        return encode_ack(packet)
    if isinstance(packet, PhyPacket):
        return encode_phy(packet, inverse=crc)
    return encode_async(packet, crc=crc)


__all__ = ["Kind", "Packet", "PacketError", "decode", "encode", "looks_like_phy"]
