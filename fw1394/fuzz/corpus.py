"""Seed corpora: packets to mutate, from hex text or from a capture.

A text file holds one packet per line as hex (spaces, ``0x`` quadlets and
``#`` comments allowed), as ``fw1394 decode`` reads them. Anything else is
read as a capture through :mod:`fw1394.capture.formats.sources` (fw1394 pcap/pcapng,
Eth1394 UDP captures, nosy dumps, kernel logs); its asynchronous packets
become the corpus, CRCs added where the source stripped them.
"""

from __future__ import annotations

from pathlib import Path

from fw1394.errors import UsageError
from fw1394.packets import PacketError
from fw1394.packets.asynchronous import decode_async, encode_async
from fw1394.packets.hextext import HexTextError, hex_bytes

#: Packets kept from one file at most (a long capture repeats itself).
LIMIT = 10_000


class CorpusError(UsageError):
    """A corpus file that cannot be read (one line for the user)."""


def load(paths: tuple[str, ...]) -> list[bytes]:
    """The packets of every file in ``paths``, in order."""
    packets: list[bytes] = []
    for path in paths:
        packets += _load_one(Path(path))
    return packets


def _load_one(path: Path) -> list[bytes]:
    try:
        head = path.read_bytes()[:4096]
    except OSError as error:
        raise CorpusError(f"{path}: {error.strerror or error}") from None
    if _is_hex_text(head):
        return _hex_lines(path)
    return _capture(path)


def _is_hex_text(head: bytes) -> bool:
    try:
        text = head.decode("ascii")
    except UnicodeDecodeError:
        return False
    for line in text.splitlines():
        body = line.split("#", 1)[0].replace("0x", "").replace(",", " ").split()
        if body:
            return all(all(c in "0123456789abcdefABCDEF" for c in token) for token in body)
    return False


def _hex_lines(path: Path) -> list[bytes]:
    packets = []
    for number, line in enumerate(path.read_text(errors="replace").splitlines(), 1):
        body = line.split("#", 1)[0].strip()
        if not body:
            continue
        try:
            packets.append(hex_bytes(body))
        except HexTextError as error:
            raise CorpusError(f"{path}:{number}: {error}") from None
        if len(packets) >= LIMIT:
            break
    if not packets:
        raise CorpusError(f"{path}: no packets")
    return packets


def _capture(path: Path) -> list[bytes]:
    try:
        from fw1394.capture.formats import sources
        from fw1394.capture.formats.record import RecordType
    except ImportError as error:  # the capture readers need numpy
        raise CorpusError(f"{path}: reading captures needs {error.name}") from None
    packets: list[bytes] = []
    try:
        for job in sources.jobs(str(path), sources.detect(str(path))):
            batch = job()
            for index in range(len(batch)):
                record = batch.record(index)
                if record.record_type == RecordType.async_packet:
                    packets.append(_with_crcs(record.data, record.crc_present))
                if len(packets) >= LIMIT:
                    return packets
    except (ValueError, OSError) as error:
        text = str(error)  # the capture readers name the file themselves
        raise CorpusError(text if text.startswith(str(path)) else f"{path}: {text}") from None
    if not packets:
        raise CorpusError(f"{path}: no asynchronous packets in the capture")
    return packets


def _with_crcs(raw: bytes, crc_present: bool) -> bytes:
    if crc_present:
        return raw
    try:
        return encode_async(decode_async(raw, crc=False))
    except PacketError:
        return raw
