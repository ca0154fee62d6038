"""Records as columns: what every reader produces and every view consumes.

A :class:`Batch` holds a run of records as numpy arrays over one byte
buffer. fw1394's own pcap/pcapng files become batches without a Python loop
(:func:`from_fw1394_chunk`); the other readers build :class:`BusRecord`
objects and pack them with :func:`from_records`.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from fw1394.capture.formats import pseudo_header as ph
from fw1394.capture.formats.containers import Issue, PacketChunk
from fw1394.capture.formats.record import BusRecord, Direction, RecordType
from fw1394.packets.ack import ACK_CODE_MASK

_I64 = np.int64


def quadlet_view(buf: np.ndarray) -> np.ndarray:
    """A uint8 buffer seen as big-endian quadlets, without a copy.

    Gather what is needed from it and convert only that (``astype(np.uint32)``):
    cheaper than converting a whole chunk of which a fraction is read.
    """
    words: np.ndarray = buf[: len(buf) & ~3].view(">u4")
    return words


def quadlets_at(buf: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Big-endian quadlets of a uint8 buffer at arbitrary byte offsets, as uint32."""
    b = buf
    gathered: np.ndarray = (
        (b[offsets].astype(np.uint32) << 24)
        | (b[offsets + 1].astype(np.uint32) << 16)
        | (b[offsets + 2].astype(np.uint32) << 8)
        | b[offsets + 3].astype(np.uint32)
    )
    return gathered


@dataclass
class Batch:
    """Records ``ordinal .. ordinal + len - 1`` of a trace, as columns."""

    buf: np.ndarray  # uint8, packet bytes live here (padded at the end)
    start: np.ndarray  # offset of each packet in ``buf``
    length: np.ndarray  # packet bytes
    frame: np.ndarray  # input frame (pcap packet number, or text line number)
    position: np.ndarray  # byte offset (or line number) in the input, for messages
    ts_ns: np.ndarray
    record_type: np.ndarray
    flags: np.ndarray  # pseudo-header flag word
    speed: np.ndarray
    ack: np.ndarray  # -1: none
    generation: np.ndarray
    sender: np.ndarray  # -1: unknown
    observer: np.ndarray  # -1: passive tap
    issues: list[Issue] = field(default_factory=list)
    unit: str = "byte"
    #: The crc_valid flags are verdicts reached when the trace was written.
    crc_verdicts: bool = False
    _words: np.ndarray | None = field(default=None, repr=False)

    def __len__(self) -> int:
        return len(self.start)

    @property
    def words(self) -> np.ndarray:
        """The buffer as big-endian quadlets (for quadlet-aligned packets), not copied."""
        if self._words is None:
            self._words = quadlet_view(self.buf)
        return self._words

    def packet(self, index: int) -> bytes:
        begin = int(self.start[index])
        return self.buf[begin : begin + int(self.length[index])].tobytes()

    def flag(self, name: str) -> np.ndarray:
        spec = ph.FIELDS[f"flags.{name}"]
        return (self.flags >> spec.lsb) & spec.mask

    def record(self, index: int) -> BusRecord:
        """The record at ``index`` as an object (for detailed views)."""
        header = ph.PseudoHeader(
            int(self.record_type[index]),
            int(self.speed[index]),
            int(self.flags[index]),
            max(int(self.ack[index]), 0),
            int(self.generation[index]),
            _node_byte(int(self.sender[index])),
            _node_byte(int(self.observer[index])),
        )
        return ph.to_record(header, self.packet(index), int(self.ts_ns[index]))

    def select(self, keep: np.ndarray) -> Batch:
        chosen = assemble(self.buf, [c[keep] for c in self._columns()], self.issues, self.unit)
        chosen.crc_verdicts = self.crc_verdicts
        return chosen

    def _columns(self) -> tuple[np.ndarray, ...]:
        return (
            self.start,
            self.length,
            self.frame,
            self.position,
            self.ts_ns,
            self.record_type,
            self.flags,
            self.speed,
            self.ack,
            self.generation,
            self.sender,
            self.observer,
        )


def assemble(
    buf: np.ndarray, columns: Sequence[np.ndarray], issues: list[Issue], unit: str = "byte"
) -> Batch:
    """A batch from its buffer and its 12 columns in :meth:`Batch._columns` order."""
    c = columns
    return Batch(
        buf,
        c[0],
        c[1],
        c[2],
        c[3],
        c[4],
        c[5],
        c[6],
        c[7],
        c[8],
        c[9],
        c[10],
        c[11],
        issues=issues,
        unit=unit,
    )


def _node_byte(value: int) -> int:
    return ph.NO_NODE if value < 0 else value


def empty(unit: str = "byte") -> Batch:
    zero = np.zeros(0, _I64)
    return assemble(np.zeros(8, np.uint8), [zero] * 12, [], unit)


def concat(batches: Sequence[Batch]) -> Batch:
    """One batch of all records (buffers are joined, starts shifted)."""
    batches = [b for b in batches if len(b) or b.issues]
    if not batches:
        return empty()
    if len(batches) == 1:
        return batches[0]
    shifts = np.cumsum([0] + [len(b.buf) for b in batches[:-1]])
    columns = [np.concatenate([b.start + s for b, s in zip(batches, shifts, strict=True)])]
    for index in range(1, 12):
        columns.append(np.concatenate([b._columns()[index] for b in batches]))
    return assemble(
        np.concatenate([b.buf for b in batches]),
        columns,
        [issue for b in batches for issue in b.issues],
        batches[0].unit,
    )


def from_records(
    records: Sequence[BusRecord],
    frames: Sequence[int],
    positions: Sequence[int] | None = None,
    issues: list[Issue] | None = None,
    unit: str = "byte",
) -> Batch:
    """Pack record objects; each packet starts on a quadlet boundary of the buffer."""
    sizes = np.array([len(r.data) for r in records], _I64)
    padded = (sizes + 3) & ~3
    starts = np.concatenate([[0], np.cumsum(padded)[:-1]]).astype(_I64) if len(records) else sizes
    buf = np.zeros(int(padded.sum()) + 64, np.uint8)
    for record, begin in zip(records, starts.tolist(), strict=True):
        buf[begin : begin + len(record.data)] = np.frombuffer(record.data, np.uint8)
    flags = [ph.encode_flags(r, crc_valid=False) for r in records]

    def column(values: Sequence[int]) -> np.ndarray:
        return np.array(values, _I64)

    return assemble(
        buf,
        [
            starts,
            sizes,
            column(frames),
            column(positions if positions is not None else frames),
            column([r.timestamp_ns for r in records]),
            column([int(r.record_type) for r in records]),
            column(flags),
            column([r.speed for r in records]),
            column([-1 if r.ack is None else r.ack for r in records]),
            column([r.generation for r in records]),
            column([-1 if r.sender is None else r.sender for r in records]),
            column([-1 if r.observer is None else r.observer for r in records]),
        ],
        issues or [],
        unit,
    )


def from_fw1394_chunk(chunk: PacketChunk, keep: np.ndarray | None = None) -> Batch:
    """Decode the pseudo-headers of a chunk's fw1394-link-type packets, with numpy."""
    buf = np.frombuffer(chunk.buf, np.uint8)
    frames = chunk.first_frame + np.arange(len(chunk), dtype=_I64)
    start, length, ts_ns, position = chunk.start, chunk.length, chunk.ts_ns, chunk.position
    if keep is not None:
        start, length, ts_ns, position, frames = (
            a[keep] for a in (start, length, ts_ns, position, frames)
        )
    heads = np.minimum(start, len(buf) - 16)
    batch_words = None
    if not (heads & 3).any():
        batch_words = quadlet_view(buf)
        first = heads >> 2
        head_words = [
            batch_words[first + i].astype(np.uint32) for i in range(ph.HEADER_LENGTH // 4)
        ]
    else:
        head_words = [quadlets_at(buf, heads + 4 * i) for i in range(ph.HEADER_LENGTH // 4)]

    def value(name: str) -> np.ndarray:
        spec = ph.FIELDS[name]
        # Bit position of the field inside the big-endian quadlet that holds it.
        unit_lsb = 8 * (4 - spec.byte_offset % 4 - spec.byte_size)
        word = head_words[spec.byte_offset // 4]
        result: np.ndarray = ((word >> (unit_lsb + spec.lsb)) & spec.mask).astype(_I64)
        return result

    header_length = value("header_length")
    record_type = value("record_type")
    good = (
        (length >= ph.HEADER_LENGTH)
        & (value("version") == ph.VERSION)
        & (header_length >= ph.HEADER_LENGTH)
        & (header_length <= length)
        & (record_type <= max(RecordType))
    )
    issues = list(chunk.issues)
    for bad in np.flatnonzero(~good)[:100]:
        issues.append(Issue(int(position[bad]), "record has no usable fw1394 pseudo-header"))
    flags = _flags_word(value)
    ack = np.where(flags & ph.flag_bit("ack_present"), value("ack") & ACK_CODE_MASK, -1)
    sender, observer = value("sender"), value("observer")
    columns = [
        start + header_length,
        length - header_length,
        frames,
        position,
        ts_ns,
        record_type,
        flags,
        value("speed"),
        ack,
        value("generation"),
        np.where(sender == ph.NO_NODE, -1, sender),
        np.where(observer == ph.NO_NODE, -1, observer),
    ]
    if not good.all():
        columns = [c[good] for c in columns]
    batch = assemble(buf, columns, issues)
    batch._words = batch_words
    batch.crc_verdicts = True
    return batch


def _flags_word(value: Callable[[str], np.ndarray]) -> np.ndarray:
    """The whole 16-bit flags unit, rebuilt from its named parts."""
    flags = np.zeros(0, _I64)
    for name, spec in ph.FIELDS.items():
        if name.startswith("flags."):
            part = value(name) << spec.lsb
            flags = part if not len(flags) else flags | part
    return flags


def direction_name(value: int) -> str:
    try:
        return Direction(value).name
    except ValueError:
        return f"reserved_{value}"


def header_quadlets(batch: Batch, rows: np.ndarray | None, count: int) -> np.ndarray:
    """(rows, count) uint32: the first ``count`` quadlets of each chosen packet (0 past its end).

    ``rows`` None means every record.
    """
    starts = batch.start if rows is None else batch.start[rows]
    lengths = batch.length if rows is None else batch.length[rows]
    out = np.empty((len(starts), count), np.uint32)
    starts = np.minimum(starts, len(batch.buf) - 4 * count - 4)
    aligned = not (starts & 3).any()
    first_word = starts >> 2
    for k in range(count):
        # Chunks end with zero padding, so reading a little past a packet is safe.
        if aligned:
            out[:, k] = batch.words[first_word + k]
        else:
            out[:, k] = quadlets_at(batch.buf, starts + 4 * k)
    short = np.flatnonzero(lengths < 4 * count)
    if len(short):
        present = lengths[short, None] >= 4 * (np.arange(count) + 1)
        out[short] = np.where(present, out[short], 0)
    result: np.ndarray = out
    return result
