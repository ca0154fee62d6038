"""Ack packets: eight bits, a 4-bit code followed by its one's complement."""

from __future__ import annotations

from dataclasses import dataclass

from construct import BitStruct, ConstructError, Nibble

from fw1394.packets.enums import AckCode, name_of
from fw1394.packets.errors import PacketError

ACK_LAYOUT = BitStruct("code" / Nibble, "parity" / Nibble)
#: Ack codes have four bits: 16 of them.
ACK_CODES: int = 1 << int(
    next(f.subcon.length for f in ACK_LAYOUT.subcon.subcons if f.name == "code")
)


#: Keeps the bits of an ack code (where a byte or an int holds one).
ACK_CODE_MASK = ACK_CODES - 1


def _parity(code: int) -> int:
    # The check nibble is the code's one's complement.
    return code ^ ACK_CODE_MASK


#: The wire byte of every ack code (code and parity as the layout places them).
ACK_BYTES: tuple[int, ...] = tuple(
    ACK_LAYOUT.build({"code": code, "parity": _parity(code)})[0] for code in range(ACK_CODES)
)
_FIELDS_OF_BYTE = tuple(ACK_LAYOUT.parse(bytes([byte])) for byte in range(256))
#: Code and parity-check result of every possible byte, looked up by the byte.
_CODE_OF_BYTE: tuple[int, ...] = tuple(int(f.code) for f in _FIELDS_OF_BYTE)
_PARITY_OK: tuple[bool, ...] = tuple(f.parity == _parity(f.code) for f in _FIELDS_OF_BYTE)


def ack_byte(code: int) -> int:
    """The wire byte of ack ``code`` (its low four bits): code, then the parity nibble."""
    return ACK_BYTES[code & ACK_CODE_MASK]


def ack_code(byte: int) -> int:
    """The ack code an ack byte carries, whatever its parity."""
    return _CODE_OF_BYTE[byte]


def ack_parity_ok(byte: int) -> bool:
    """Whether an ack byte's parity nibble is the complement of its code."""
    return _PARITY_OK[byte]


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
        return None if self.parity is None else self.parity == _parity(self.code)

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
    parity = _parity(ack.code) if ack.parity is None else ack.parity
    try:
        return bytes(ACK_LAYOUT.build({"code": ack.code, "parity": parity}))
    except ConstructError:
        raise PacketError("code", f"{ack.code!r} is not a 4-bit ack code") from None
