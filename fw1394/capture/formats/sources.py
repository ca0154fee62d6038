"""Open any supported trace: tell its format, and read it as batches of records.

Formats:

``fw1394``  fw1394's own pcap/pcapng (link type LINKTYPE_USER0 with the
            pseudo-header of :mod:`fw1394.capture.formats.pseudo_header`);
``udp``     pcap/pcapng of UDP port 1394 carrying JHU Eth1394 datagrams;
``nosy``    nosy-dump ``--output`` files;
``kernel``  Linux kernel text: firewire tracepoints and firewire-ohci debug lines.

The two pcap formats share one reader, which handles each packet by its
link type, so a file mixing both is read whole whichever is named.
"""

from __future__ import annotations

import io
import struct
from collections.abc import Callable, Iterator
from functools import partial
from typing import Any, BinaryIO

import numpy as np

from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import containers, kernel, nosy
from fw1394.capture.formats import eth1394_udp as udp
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.containers import Issue, PacketChunk
from fw1394.capture.formats.pseudo_header import LINKTYPE_FW1394
from fw1394.capture.formats.record import BusRecord
from fw1394.errors import UsageError
from fw1394.packets.eth1394 import UDP_PORT

FORMATS = ("fw1394", "udp", "nosy", "kernel")
#: Work that yields a batch; the heavy numpy part can run on another thread.
Job = Callable[[], Batch]


class SourceError(UsageError):
    """The input cannot be read at all (one line for the user)."""


#: Bytes looked at to tell a format.
HEAD_SIZE = 65536
#: The name standing for standard input, as in tshark.
STDIN = "-"


def detect(path: str) -> str:
    try:
        with open(path, "rb") as stream:
            head = stream.read(HEAD_SIZE)
    except OSError as error:
        raise SourceError(f"{path}: {error.strerror or error}") from None
    return detect_head(head, path)


def detect_head(head: bytes, path: str) -> str:
    """The format of an input whose first bytes are ``head``."""
    if not head:
        raise SourceError(f"{path}: the file is empty")
    kind = containers.sniff(head)
    if kind is not None:
        return "fw1394" if _first_linktype(head, kind) == LINKTYPE_FW1394 else "udp"
    text = head.decode("utf-8", "replace")
    printable = sum(ch.isprintable() or ch in "\r\n\t" for ch in text) / max(len(text), 1)
    if printable > 0.95:
        if kernel.looks_like_kernel_text(text):
            return "kernel"
        raise SourceError(f"{path}: text, but no firewire kernel lines in its first 64 KiB")
    if nosy.plausible(head):
        return "nosy"
    raise SourceError(f"{path}: cannot tell the format; name it with --format")


def _first_linktype(head: bytes, kind: str) -> int | None:
    if kind == "pcap":
        if len(head) < 24:
            return None
        order = "<" if head[:4] in (b"\xd4\xc3\xb2\xa1", b"\x4d\x3c\xb2\xa1") else ">"
        return int(struct.unpack_from(order + "I", head, 20)[0] & 0x0FFFFFFF)
    if len(head) < 12:
        return None
    order = "<" if struct.unpack_from("<I", head, 8)[0] == 0x1A2B3C4D else ">"
    offset = 0
    while offset + 12 <= len(head):
        block_type, length = struct.unpack_from(order + "II", head, offset)
        if block_type == 1 and offset + 10 <= len(head):
            return int(struct.unpack_from(order + "H", head, offset + 8)[0])
        if length < 12:
            return None
        offset += length
    return None


def jobs(path: str, fmt: str, ports: tuple[int, ...] = (UDP_PORT,)) -> Iterator[Job]:
    """Batches of ``path`` read as ``fmt``, as jobs to run in order.

    ``ports`` are the UDP ports whose datagrams are taken as Eth1394.
    """
    try:
        stream = open(path, "rb")  # noqa: SIM115 - closed when the generator ends
    except OSError as error:
        raise SourceError(f"{path}: {error.strerror or error}") from None
    with stream:
        yield from stream_jobs(stream, fmt, ports)


def stream_jobs(stream: BinaryIO, fmt: str, ports: tuple[int, ...] = (UDP_PORT,)) -> Iterator[Job]:
    """Batches of an open stream read as ``fmt`` (standard input, a pipe)."""
    if fmt in ("fw1394", "udp"):
        yield from _pcap_jobs(stream, ports)
    elif fmt == "nosy":
        for batch in nosy.read_batches(stream):
            yield partial(_ready, batch)
    elif fmt == "kernel":
        text = io.TextIOWrapper(stream, encoding="utf-8", errors="replace", newline=None)
        for batch in kernel.read_batches(text):
            yield partial(_ready, batch)
    else:
        raise SourceError(f"unknown format {fmt!r}")


class _Prefixed(io.RawIOBase):
    """Bytes already read (to tell the format), then the rest of the stream."""

    def __init__(self, head: bytes, rest: BinaryIO) -> None:
        self._head = memoryview(head)
        self._rest = rest

    def readable(self) -> bool:
        return True

    def readinto(self, target: Any) -> int:
        if self._head:
            size = min(len(target), len(self._head))
            target[:size] = self._head[:size]
            self._head = self._head[size:]
            return size
        read1 = getattr(self._rest, "read1", self._rest.read)
        data = read1(len(target))
        target[: len(data)] = data
        return len(data)


def open_stream(stream: BinaryIO) -> tuple[BinaryIO, bytes]:
    """``stream`` ready to read from its start, and its first bytes to tell the format by.

    Reads no more than the format needs, so a live pipe (``capture -w - | dissect -``)
    is recognised as soon as its file header has arrived.
    """
    head = b""
    read1 = getattr(stream, "read1", stream.read)
    while len(head) < HEAD_SIZE:
        data = read1(HEAD_SIZE - len(head))
        if not data:
            break
        head += data
        kind = containers.sniff(head)
        if kind is not None and _first_linktype(head, kind) is not None:
            break
    return io.BufferedReader(_Prefixed(head, stream)), head


class PortTally(tuple[int, ...]):
    """The UDP ports taken as Eth1394, counting the ports of the datagrams passed over.

    A datagram is asked about by its source and destination port; those whose
    ports are both refused are the traffic to suggest ``--port`` for.
    """

    def __init__(self, ports: tuple[int, ...]) -> None:
        self.refused: dict[int, int] = {}

    def __contains__(self, port: object) -> bool:
        if super().__contains__(port):
            return True
        if isinstance(port, int):
            self.refused[port] = self.refused.get(port, 0) + 1
        return False

    def busiest(self, most: int = 3) -> list[int]:
        return sorted(self.refused, key=lambda p: -self.refused[p])[:most]


def _ready(batch: Batch) -> Batch:
    return batch


def _pcap_jobs(stream: BinaryIO, ports: tuple[int, ...]) -> Iterator[Job]:
    try:
        chunks = containers.read_chunks(stream)
        decoder = udp.Eth1394Decoder()
        for chunk in chunks:
            own = chunk.linktype == LINKTYPE_FW1394
            if own.all():
                yield partial(batches.from_fw1394_chunk, chunk)
            else:
                # Eth1394 decoding keeps state (the bus generation): do it here, in order.
                foreign = _foreign(chunk, np.flatnonzero(~own), decoder, ports)
                yield partial(_mixed, chunk, own, foreign)
    except containers.FormatError as error:
        raise SourceError(str(error)) from None


def _mixed(chunk: PacketChunk, own: np.ndarray, foreign: Batch) -> Batch:
    if not own.any():
        foreign.issues[:0] = chunk.issues
    parts = [batches.from_fw1394_chunk(chunk, keep=own), foreign] if own.any() else [foreign]
    joined = batches.concat(parts)
    order = np.argsort(joined.frame, kind="stable")
    return joined.select(order) if len(parts) > 1 else joined


def _foreign(
    chunk: PacketChunk, rows: np.ndarray, decoder: udp.Eth1394Decoder, ports: tuple[int, ...]
) -> Batch:
    """Eth1394 records from the packets of other link types."""
    records: list[BusRecord] = []
    frames: list[int] = []
    positions: list[int] = []
    issues: list[Issue] = []
    for row in rows.tolist():
        frame = chunk.first_frame + row
        position = int(chunk.position[row])
        found = udp.udp_payload(int(chunk.linktype[row]), chunk.packet(row), ports)
        if found is None:
            continue
        if isinstance(found, str):
            issues.append(Issue(position, f"frame {frame}: {found}"))
            continue
        result = decoder.records(found, int(chunk.ts_ns[row]))
        if isinstance(result, Issue):
            issues.append(Issue(position, f"frame {frame}: {result.message}"))
            continue
        for record in result or []:
            records.append(record)
            frames.append(frame)
            positions.append(position)
    return batches.from_records(records, frames, positions, issues)
