"""Packets written as hex text, the way people paste them: quadlets, spaces, ``0x``."""

from __future__ import annotations

from fw1394.errors import UsageError


class HexTextError(UsageError):
    """Text that is not hex bytes (the message says where)."""


def hex_bytes(text: str) -> bytes:
    """Bytes from hex that may contain spaces, newlines, ``0x`` prefixes, either case.

    Quadlets written as ``0x1f`` stand for a whole 8-digit quadlet, so tokens with a
    ``0x`` prefix are zero-filled to 8 digits; bare tokens are taken as they are.
    """
    digits = []
    for token in text.replace(",", " ").split():
        if token.lower().startswith("0x"):
            body = token[2:]
            if len(body) > 8 or not body:
                raise HexTextError(f"{token!r}: a 0x quadlet has 1 to 8 hex digits")
            token = body.rjust(8, "0")
        digits.append(token)
    joined = "".join(digits)
    if len(joined) % 2:
        raise HexTextError(f"odd number of hex digits ({len(joined)}): {text.strip()[:60]!r}")
    try:
        return bytes.fromhex(joined)
    except ValueError:
        bad = next((c for c in joined if c not in "0123456789abcdefABCDEF"), "?")
        raise HexTextError(f"{bad!r} is not a hex digit in {text.strip()[:60]!r}") from None


def quadlets_hex(raw: bytes) -> str:
    """Space-separated 8-digit quadlets (a shorter tail is printed as it is)."""
    return " ".join(raw[i : i + 4].hex() for i in range(0, len(raw), 4))
