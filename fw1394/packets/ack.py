"""Ack packets: eight bits, a 4-bit code followed by its one's complement."""

from __future__ import annotations

from dataclasses import dataclass

from construct import BitStruct, ConstructError, Nibble

from fw1394.packets.enums import AckCode, name_of
from fw1394.packets.errors import PacketError

ACK_LAYOUT = BitStruct("code" / Nibble, "parity" / Nibble)


@dataclass(frozen=True, slots=True)
class Ack:
    """An acknowledge; ``parity`` is the received check nibble (``None``: computed)."""

    code: int = AckCode.ack_complete
    parity: int | None = None

    @property
    def kind(self) -> str:
        return "ack"

    @property
    def name(self) -> str:
        return name_of(AckCode, self.code)

    @property
    def parity_ok(self) -> bool | None:
        return None if self.parity is None else self.parity == self.code ^ 0xF

    @property
    def problems(self) -> tuple[PacketError, ...]:
        if self.parity_ok is False:
            return (
                PacketError("parity", f"{self.parity:#x} is not the complement of {self.code:#x}"),
            )
        return ()

    # An ack is complete, pending, busy or an error by its code's two top bits.
    @property
    def is_busy(self) -> bool:
        return self.code >> 2 == 1

    @property
    def is_error(self) -> bool:
        return self.code >> 2 == 3


def decode_ack(raw: bytes) -> Ack:
    if len(raw) != 1:
        raise PacketError("length", f"an ack is one byte, not {len(raw)}")
    parsed = ACK_LAYOUT.parse(raw)
    return Ack(parsed.code, parsed.parity)


def encode_ack(ack: Ack) -> bytes:
    parity = ack.code ^ 0xF if ack.parity is None else ack.parity
    try:
        return bytes(ACK_LAYOUT.build({"code": ack.code, "parity": parity}))
    except ConstructError:
        raise PacketError("code", f"{ack.code!r} is not a 4-bit ack code") from None
