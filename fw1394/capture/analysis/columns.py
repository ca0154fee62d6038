"""Header fields of every record of a batch, decoded with numpy from the layouts.

The bit positions come from :data:`fw1394.packets.LAYOUTS` (the
``Quadlets.bitfields`` of each layout); nothing here says where a field sits.
Every field is an int64 column, -1 where the record's kind has no such field.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from enum import IntFlag

import numpy as np

from fw1394.capture.analysis.crcvec import crc_of_blocks, crc_of_columns
from fw1394.capture.formats import pseudo_header as ph
from fw1394.capture.formats.batch import Batch, header_quadlets, quadlets_at
from fw1394.capture.formats.record import RecordType
from fw1394.packets import LAYOUTS
from fw1394.packets.accessors import TCODE
from fw1394.packets.ack import ack_code, ack_parity_ok
from fw1394.packets.layouts import TCODE_SHIFT

_I64 = np.int64
#: Header quadlets read for every packet: the longest header, without its CRC.
HEADER_QUADLETS = max(layout.header.count for layout in LAYOUTS.values())
#: Every header field name of every layout, in first-appearance order.
FIELD_NAMES: tuple[str, ...] = tuple(
    dict.fromkeys(
        name
        for layout in LAYOUTS.values()
        for name in layout.sealed_header.names
        if name != "header_crc"
    )
)
#: Code and parity check of every ack byte, for lookups by a column of bytes.
_ACK_CODE = np.array([ack_code(byte) for byte in range(256)], _I64)
_ACK_PARITY_OK = np.array([ack_parity_ok(byte) for byte in range(256)])


class Problem(IntFlag):
    """What is wrong with a record, as found by the bulk decoder."""

    truncated = 0x001  # shorter than its header
    data_short = 0x002  # data block shorter than data_length, or no data CRC after it
    trailing = 0x004  # bytes after the end of the packet
    header_crc = 0x008
    data_crc = 0x010
    unknown_tcode = 0x020  # no layout for this tcode
    phy_check = 0x040  # PHY check quadlet is not the complement
    ack_parity = 0x080  # ack record's parity nibble is wrong
    bad_record = 0x100  # record too short for its record type


PROBLEM_TEXT = {
    Problem.truncated: "truncated header",
    Problem.data_short: "data block (or its CRC) cut short",
    Problem.trailing: "bytes after the end of the packet",
    Problem.header_crc: "header CRC error",
    Problem.data_crc: "data CRC error",
    Problem.unknown_tcode: "tcode has no packet layout",
    Problem.phy_check: "PHY check quadlet is not the complement",
    Problem.ack_parity: "ack parity error",
    Problem.bad_record: "record too short for its type",
}
CRC_PROBLEMS = Problem.header_crc | Problem.data_crc | Problem.phy_check


def problem_names(bits: int) -> list[str]:
    return [text for flag, text in PROBLEM_TEXT.items() if bits & flag]


def _tcode_table(values: dict[int, int], default: int = -1) -> np.ndarray:
    table = np.full(17, default, _I64)  # index 16: "no tcode" (-1 wraps to it)
    for code, value in values.items():
        table[code] = value
    return table


#: Per tcode (index 16 for records without one): header bytes before the CRC, data block.
_HEADER_SIZE = _tcode_table({int(t): layout.header_size for t, layout in LAYOUTS.items()})
_HAS_DATA = _tcode_table({int(t): int(layout.has_data) for t, layout in LAYOUTS.items()}, 0)
_HEADER_COUNT = _tcode_table({int(t): layout.header.count for t, layout in LAYOUTS.items()}, 0)


def _field_plans() -> dict[str, list[tuple[np.ndarray, tuple[tuple[int, int, int, int], ...]]]]:
    """For each field: (which tcodes, its bit pieces) for every distinct placement."""
    plans: dict[str, dict[tuple[tuple[int, int, int, int], ...], list[int]]] = {}
    for code, layout in LAYOUTS.items():
        pieces: dict[str, list[tuple[int, int, int, int]]] = {}
        for bit in layout.header.bitfields:
            pieces.setdefault(bit.name, []).append((bit.quadlet, bit.lsb, bit.mask, bit.shift))
        for name, parts in pieces.items():
            plans.setdefault(name, {}).setdefault(tuple(parts), []).append(int(code))
    result = {}
    for name, placements in plans.items():
        result[name] = [
            (_tcode_table(dict.fromkeys(codes, 1), 0).astype(bool), parts)
            for parts, codes in placements.items()
        ]
    return result


_PLANS = _field_plans()


class Fields(Mapping[str, np.ndarray]):
    """Header fields computed on first use from the header quadlets (-1 where absent)."""

    def __init__(self, quads: np.ndarray, tcode: np.ndarray) -> None:
        self._quads = quads
        self._tcode = tcode
        self._cache: dict[str, np.ndarray] = {}

    def __getitem__(self, name: str) -> np.ndarray:
        if name not in self._cache:
            self._cache[name] = self._compute(name)
        return self._cache[name]

    def __iter__(self) -> Iterator[str]:
        return iter(FIELD_NAMES)

    def __len__(self) -> int:
        return len(FIELD_NAMES)

    def select(self, keep: np.ndarray) -> Fields:
        return Fields(self._quads[keep], self._tcode[keep])

    def _compute(self, name: str) -> np.ndarray:
        result = np.full(len(self._tcode), -1, _I64)
        for codes, parts in _PLANS[name]:
            rows = codes[self._tcode]
            if not rows.any():
                continue
            value = self._piece(*parts[0])
            for part in parts[1:]:
                value = value | self._piece(*part)
            result = value.astype(_I64) if rows.all() else np.where(rows, value, result)
        return result

    def _piece(self, quadlet: int, lsb: int, mask: int, shift: int) -> np.ndarray:
        # Stay in uint32 unless the piece belongs above bit 31 (the offset's high part).
        piece: np.ndarray = self._quads[:, quadlet]
        if lsb:
            piece = piece >> np.uint32(lsb)
        if mask != 0xFFFFFFFF:
            piece = piece & np.uint32(mask)
        if shift:
            piece = piece.astype(_I64) << shift
        return piece


@dataclass
class Decoded:
    """Per-record decoded columns, aligned with the batch."""

    tcode: np.ndarray  # -1 for records that are not asynchronous packets
    fields: Fields
    problems: np.ndarray
    data_start: np.ndarray  # offset of the data block in the buffer, -1 if none
    data_present: np.ndarray  # bytes of data block present

    def select(self, keep: np.ndarray) -> Decoded:
        return Decoded(
            self.tcode[keep],
            self.fields.select(keep),
            self.problems[keep],
            self.data_start[keep],
            self.data_present[keep],
        )


def decode(batch: Batch, verify_crc: bool | None = None) -> Decoded:
    """Decode every record of ``batch``.

    CRCs are recomputed for every record that carries them when
    ``verify_crc`` is True. When it is None (the default), records whose
    pseudo-header says their CRCs were checked and found good when the trace
    was written (fw1394's own traces) are taken at their word, and only the
    others are recomputed.
    """
    count = len(batch)
    problems = np.zeros(count, _I64)
    is_async = batch.record_type == RecordType.async_packet
    quads = header_quadlets(batch, None, HEADER_QUADLETS)
    crc_present = (batch.flags & ph.flag_bit("crc_present")) != 0
    checkable = crc_present & ((batch.flags & ph.flag_bit("crc_placeholder")) == 0)
    partial = (batch.flags & ph.flag_bit("partial")) != 0

    short = is_async & (batch.length < 4)
    problems[short] |= Problem.truncated
    found = ((quads[:, TCODE.quadlet] >> TCODE.shift) & TCODE.mask).astype(_I64)
    tcode = np.where(is_async & ~short, found, -1)
    header_size = _HEADER_SIZE[tcode]
    problems[(tcode >= 0) & (header_size < 0)] |= Problem.unknown_tcode
    fields = Fields(quads, tcode)

    known = header_size >= 0
    crc_bytes = 4 * crc_present
    header_bytes = header_size + crc_bytes
    length = batch.length
    problems[known & (length < header_bytes)] |= Problem.truncated
    has_data = _HAS_DATA[tcode].astype(bool)
    data_length = fields["data_length"]
    expected = np.where(has_data, header_bytes + ((data_length + 3) & ~3) + crc_bytes, header_bytes)
    short_data = has_data & ~partial & (length >= header_bytes) & (length < expected)
    problems[short_data] |= Problem.data_short
    problems[known & (length > expected)] |= Problem.trailing
    data_start = np.where(has_data, batch.start + header_bytes, -1)
    data_present = np.where(has_data, np.clip(length - header_bytes, 0, None), 0)

    if verify_crc is not False:
        if verify_crc is None and batch.crc_verdicts:
            checkable &= (batch.flags & ph.flag_bit("crc_valid")) == 0
        _check_header_crcs(tcode, quads, checkable, batch, problems)
        _check_data_crcs(batch, data_length, data_start, data_present, checkable, problems)
    _check_phy_and_ack(batch, quads, crc_present, problems)
    return Decoded(tcode, fields, problems, data_start, data_present)


def _check_header_crcs(
    tcode: np.ndarray, quads: np.ndarray, checkable: np.ndarray, batch: Batch, problems: np.ndarray
) -> None:
    counts = _HEADER_COUNT[tcode]
    rows = np.flatnonzero((counts > 0) & checkable & (batch.length >= 4 * (counts + 1)))
    if not len(rows):
        return
    computed = crc_of_columns(quads[rows], counts[rows])
    stored = quadlets_at(batch.buf, batch.start[rows] + 4 * counts[rows])
    problems[rows[computed != stored]] |= Problem.header_crc


def _check_data_crcs(
    batch: Batch,
    data_length: np.ndarray,
    data_start: np.ndarray,
    data_present: np.ndarray,
    checkable: np.ndarray,
    problems: np.ndarray,
) -> None:
    padded = (data_length + 3) & ~3
    rows = np.flatnonzero(
        (data_start >= 0) & checkable & (data_present >= padded + 4) & (padded >= 0)
    )
    if not len(rows):
        return
    computed = crc_of_blocks(batch.buf, data_start[rows], padded[rows] // 4, batch.words)
    stored = quadlets_at(batch.buf, data_start[rows] + padded[rows])
    problems[rows[computed != stored]] |= Problem.data_crc


def _check_phy_and_ack(
    batch: Batch, quads: np.ndarray, crc_present: np.ndarray, problems: np.ndarray
) -> None:
    kinds = batch.record_type
    phy = kinds == RecordType.phy_packet
    needed = np.where(crc_present, 8, 4)
    problems[phy & (batch.length < needed)] |= Problem.bad_record
    checked = phy & crc_present & (batch.length >= 8)
    problems[checked & ((quads[:, 0] ^ quads[:, 1]) != 0xFFFFFFFF)] |= Problem.phy_check
    ack = kinds == RecordType.ack
    problems[ack & (batch.length < 1)] |= Problem.bad_record
    rows = np.flatnonzero(ack & (batch.length >= 1))
    if len(rows):
        byte = batch.buf[batch.start[rows]]
        problems[rows[~_ACK_PARITY_OK[byte]]] |= Problem.ack_parity


def ack_codes(batch: Batch) -> np.ndarray:
    """The code carried by ack records (-1 for other records)."""
    codes = np.full(len(batch), -1, _I64)
    rows = np.flatnonzero((batch.record_type == RecordType.ack) & (batch.length >= 1))
    codes[rows] = _ACK_CODE[batch.buf[batch.start[rows]]]
    return codes


__all__ = ["FIELD_NAMES", "TCODE_SHIFT", "Decoded", "Problem", "decode"]
