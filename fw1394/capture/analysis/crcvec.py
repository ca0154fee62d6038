"""CRC-32/BZIP2 of many packets at once, one quadlet per numpy step.

The same function as :func:`fw1394.crc.crc32` (polynomial 0x04C11DB7, MSB
first, register starting and ending complemented), restated for numpy: the
register after taking in one big-endian quadlet ``q`` is ``f(register ^ q)``,
where ``f`` shifts 32 zero bits through the register. ``f`` is linear, so it
is two lookups in 64 Ki-entry tables, one per half of its argument.
"""

from __future__ import annotations

import numpy as np

from fw1394.capture.formats.batch import quadlets_at

POLYNOMIAL = 0x04C11DB7
_MASK = 0xFFFFFFFF


def _shift32(register: int) -> int:
    for _ in range(32):
        register = (
            (register << 1) ^ POLYNOMIAL if register & 0x80000000 else register << 1
        ) & _MASK
    return register


def _tables() -> tuple[np.ndarray, np.ndarray]:
    # f(b << 8k) for each byte b and byte position k, then combined per 16-bit half.
    by_byte = [np.array([_shift32(b << (8 * k)) for b in range(256)], np.uint32) for k in range(4)]
    halves = np.arange(1 << 16, dtype=np.uint32)
    low = by_byte[1][halves >> 8] ^ by_byte[0][halves & 0xFF]
    high = by_byte[3][halves >> 8] ^ by_byte[2][halves & 0xFF]
    return high, low


_HIGH, _LOW = _tables()


def step(register: np.ndarray, quadlet: np.ndarray) -> np.ndarray:
    """Registers after each takes in its quadlet (both uint32 arrays)."""
    x = register ^ quadlet
    result: np.ndarray = _HIGH[x >> 16] ^ _LOW[x & 0xFFFF]
    return result


def crc_of_columns(quadlets: np.ndarray, counts: np.ndarray) -> np.ndarray:
    """CRC of the first ``counts[i]`` quadlets of row ``i`` of a (rows, k) uint32 array."""
    register = np.full(len(quadlets), _MASK, np.uint32)
    for k in range(quadlets.shape[1] if len(quadlets) else 0):
        active = counts > k
        if not active.any():
            break
        register = np.where(active, step(register, quadlets[:, k]), register)
    result: np.ndarray = register ^ np.uint32(_MASK)
    return result


def crc_of_blocks(
    buf: np.ndarray, starts: np.ndarray, counts: np.ndarray, words: np.ndarray | None = None
) -> np.ndarray:
    """CRC of ``counts[i]`` quadlets at byte offset ``starts[i]`` of ``buf`` (uint8).

    ``words`` is :func:`quadlet_view` of ``buf``, used when every start is
    quadlet-aligned.
    """
    order = np.argsort(-counts, kind="stable")
    sorted_starts = starts[order]
    sorted_counts = counts[order]
    register = np.full(len(starts), _MASK, np.uint32)
    deepest = int(sorted_counts[0]) if len(sorted_counts) else 0
    # Rows are sorted longest first, so the rows still going at step k are a prefix.
    active_at = np.searchsorted(-sorted_counts, -np.arange(deepest), side="left")
    aligned = words is not None and not (sorted_starts & 3).any()
    first_word = sorted_starts >> 2
    for k in range(deepest):
        active = int(active_at[k])
        if aligned and words is not None:
            quadlet = words[first_word[:active] + k].astype(np.uint32)
        else:
            quadlet = quadlets_at(buf, sorted_starts[:active] + 4 * k)
        register[:active] = step(register[:active], quadlet)
    result: np.ndarray = np.empty_like(register)
    result[order] = register ^ np.uint32(_MASK)
    return result
