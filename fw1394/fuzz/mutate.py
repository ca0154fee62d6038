"""Mutations of wire bytes: bit flips, quadlet insertion and deletion, header field edits.

Used on a seed corpus (a capture, a list of hex packets) and on generated
packets, and by the shrinker. Header fields are read and written through the
layouts of :mod:`fw1394.packets` (see :func:`fw1394.fuzz.malform.with_header`);
everything else works on whole bytes or quadlets and needs no layout at all.
"""

from __future__ import annotations

import random
from collections.abc import Callable

from fw1394.fuzz.malform import header_of, header_size, recomputed_crcs, with_header
from fw1394.packets import LAYOUTS
from fw1394.packets.asynchronous import tcode_of

_QUADLET = 4
#: Header fields an edit never touches: the tcode picks the layout itself.
_FIXED = frozenset({"tcode"})
_EDITABLE: dict[int, tuple[str, ...]] = {
    int(tcode): tuple(sorted(n for n in layout.header.widths if n not in _FIXED))
    for tcode, layout in LAYOUTS.items()
}
_WIDTHS: dict[int, dict[str, int]] = {
    int(tcode): layout.header.widths for tcode, layout in LAYOUTS.items()
}


def flip_bit(raw: bytes, bit: int) -> bytes:
    """``raw`` with bit ``bit`` (counted from the first byte's MSB) inverted."""
    if not raw:
        return raw
    bit %= 8 * len(raw)
    index, shift = divmod(bit, 8)
    return raw[:index] + bytes([raw[index] ^ (0x80 >> shift)]) + raw[index + 1 :]


def insert_quadlet(raw: bytes, index: int, value: int) -> bytes:
    """``value`` inserted as quadlet number ``index`` (clamped to the end)."""
    at = min(max(index, 0) * _QUADLET, len(raw))
    return raw[:at] + (value & 0xFFFFFFFF).to_bytes(_QUADLET, "big") + raw[at:]


def delete_quadlet(raw: bytes, index: int) -> bytes:
    """``raw`` without quadlet number ``index`` (nothing happens past the end)."""
    at = max(index, 0) * _QUADLET
    return raw[:at] + raw[at + _QUADLET :] if at < len(raw) else raw


def zero_quadlet(raw: bytes, index: int) -> bytes:
    at = max(index, 0) * _QUADLET
    if at >= len(raw):
        return raw
    return raw[:at] + bytes(len(raw[at : at + _QUADLET])) + raw[at + _QUADLET :]


def editable_fields(raw: bytes) -> tuple[str, ...]:
    """Names of the header fields of ``raw`` an edit may change (empty if none)."""
    size = header_size(raw)
    return () if size is None else _EDITABLE[tcode_of(raw)]


def swap_fields(raw: bytes, first: str, second: str) -> bytes:
    """Two header fields exchange their values (each cut to the other's width)."""
    found = header_of(raw)
    if found is None:
        return raw
    values = found[1]
    if first not in values or second not in values:
        return raw
    return with_header(raw, {first: values[second], second: values[first]}, fix_crc=False)


def _random_flip(rng: random.Random, raw: bytes) -> bytes:
    return flip_bit(raw, rng.randrange(max(8 * len(raw), 1)))


def _random_insert(rng: random.Random, raw: bytes) -> bytes:
    return insert_quadlet(raw, rng.randrange(len(raw) // _QUADLET + 1), rng.getrandbits(32))


def _random_delete(rng: random.Random, raw: bytes) -> bytes:
    return delete_quadlet(raw, rng.randrange(max(len(raw) // _QUADLET, 1)))


def _random_swap(rng: random.Random, raw: bytes) -> bytes:
    names = editable_fields(raw)
    if len(names) < 2:
        return _random_flip(rng, raw)
    first, second = rng.sample(names, 2)
    return swap_fields(raw, first, second)


def _random_field(rng: random.Random, raw: bytes) -> bytes:
    names = editable_fields(raw)
    if not names:
        return _random_flip(rng, raw)
    name = rng.choice(names)
    width = _WIDTHS[tcode_of(raw)][name]
    top = (1 << width) - 1
    value = rng.choice((0, 1, top, top >> 1, rng.getrandbits(width)))
    return with_header(raw, {name: value}, fix_crc=False)


MUTATORS: tuple[tuple[str, Callable[[random.Random, bytes], bytes], float], ...] = (
    ("bit-flip", _random_flip, 0.40),
    ("quadlet-insert", _random_insert, 0.15),
    ("quadlet-delete", _random_delete, 0.15),
    ("field-swap", _random_swap, 0.15),
    ("field-value", _random_field, 0.15),
)
_FUNCTIONS = tuple(function for _, function, _ in MUTATORS)
_WEIGHTS = tuple(weight for _, _, weight in MUTATORS)


def havoc(rng: random.Random, raw: bytes, *, fix_crc_share: float = 0.5) -> tuple[bytes, bool]:
    """One to three random mutations; then, ``fix_crc_share`` of the time, CRCs recomputed.

    Returns the bytes and whether the CRCs were recomputed (such a packet gets
    past the CRC check and tests what lies behind it).
    """
    for function in rng.choices(_FUNCTIONS, _WEIGHTS, k=rng.randint(1, 3)):
        raw = function(rng, raw)
    if rng.random() < fix_crc_share:
        fixed = recomputed_crcs(raw)
        if fixed is not None:
            return fixed, True
    return raw, False
