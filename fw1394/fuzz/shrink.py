"""Shrinking a finding: fewer packets in its stream, then a simpler packet.

Delta debugging on the stream drops the packets the violation does not need;
then each remaining case packet is simplified (quadlets deleted, header fields
zeroed with the CRC recomputed or left wrong, data cut) while the violation
still reproduces with the same oracle and signature (its verdict class) and
the packet keeps its kind (its tcode: a quadlet write stays a quadlet write,
never a block write that happens to fail the same way). A candidate is kept
only if it is smaller (shorter, then fewer nonzero bytes), so shrinking ends.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from dataclasses import replace

from fw1394.errors import Timeout
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.malform import header_of, recomputed_crcs, with_header
from fw1394.fuzz.mutate import delete_quadlet
from fw1394.fuzz.trial import Entry

#: Replays the finding's stream on a fresh node; the (oracle, signature) pairs seen.
Replayer = Callable[[list[Entry]], set[tuple[str, str]]]
#: Header fields never zeroed: they decide where a packet goes and what it is.
_KEEP = frozenset({"tcode", "destination_id"})


class _Budget:
    def __init__(self, replays: int) -> None:
        self.left = replays


class _OutOfTime(Timeout):
    """The deadline passed: shrinking stops with the smallest stream found so far."""


def shrink(
    finding: Finding, replay: Replayer, budget: int, *, deadline: float | None = None
) -> Finding:
    """``finding`` with its stream shrunk as far as ``budget`` replays allow, and
    (``deadline``, a :func:`time.monotonic` time) as far as time allows: each
    stream kept reproduced the finding, so one cut short is still a reproducer."""
    if budget <= 0:
        return finding
    spend = _Budget(budget)
    best = list(finding.stream)

    def still(stream: list[Entry]) -> bool:
        nonlocal best
        if spend.left <= 0 or not any(e.role == "case" for e in stream):
            return False
        if deadline is not None and time.monotonic() >= deadline:
            raise _OutOfTime
        spend.left -= 1
        if finding.key not in replay(stream):
            return False
        if _smaller(stream, best):
            best = list(stream)
        return True

    stream = list(finding.stream)
    try:
        if not still(stream):
            return replace(finding, reproduced=False)
    except _OutOfTime:
        return finding
    try:
        stream = _last_batch(stream, still)
        stream = _cut_tail(stream, still)
        stream = _ddmin(stream, still)
        for index in reversed(range(len(stream))):
            if stream[index].role == "case":
                stream[index] = _simplest(stream, index, still)
    except _OutOfTime:
        stream = best
    return replace(finding, stream=stream, reproduced=True, shrunk=True)


def _smaller(stream: list[Entry], than: list[Entry]) -> bool:
    """Fewer packets, then fewer bytes, then fewer nonzero bytes."""

    def measure(entries: list[Entry]) -> tuple[int, int, int]:
        sizes = [_size(e.raw) for e in entries]
        return (len(entries), sum(s[0] for s in sizes), sum(s[1] for s in sizes))

    return measure(stream) < measure(than)


def _last_batch(stream: list[Entry], still: Callable[[list[Entry]], bool]) -> list[Entry]:
    # Most violations depend on the packet alone: one replay may save the many
    # delta debugging would spend (each a node restart, for a remote target).
    last_case = max(i for i, e in enumerate(stream) if e.role == "case")
    if last_case > 0 and still(stream[last_case:]):
        return stream[last_case:]
    return stream


def _cut_tail(stream: list[Entry], still: Callable[[list[Entry]], bool]) -> list[Entry]:
    # The violation shows in the last batch; the packets after its case are the
    # read-backs and probes of that batch, which some oracles need and some do not.
    last_case = max(i for i, e in enumerate(stream) if e.role == "case")
    for end in range(last_case + 1, len(stream)):
        if still(stream[:end]):
            return stream[:end]
    return stream


def _ddmin(stream: list[Entry], still: Callable[[list[Entry]], bool]) -> list[Entry]:
    """Drop chunks of the stream (halves, quarters, ...) while the violation stays."""
    chunk = max(len(stream) // 2, 1)
    while chunk >= 1:
        start = 0
        removed = False
        while start < len(stream) - 1:
            # The last entry stays: the violation shows there or just before.
            candidate = stream[:start] + stream[min(start + chunk, len(stream) - 1) :]
            if len(candidate) < len(stream) and still(candidate):
                stream, removed = candidate, True
            else:
                start += chunk
        if not removed:
            chunk //= 2
    return stream


def _simplest(stream: list[Entry], index: int, still: Callable[[list[Entry]], bool]) -> Entry:
    entry = stream[index]
    kind = tcode_of(entry.raw)
    improved = True
    while improved:
        improved = False
        for candidate in _candidates(entry.raw):
            if not candidate or _size(candidate) >= _size(entry.raw):
                continue  # (an empty packet is nothing sent at all)
            if tcode_of(candidate) != kind:
                continue  # another kind of packet: another root cause
            trial = [*stream[:index], entry._replace(raw=candidate), *stream[index + 1 :]]
            if still(trial):
                entry, improved = trial[index], True
                break
    return entry


def tcode_of(raw: bytes) -> int | None:
    """The tcode in a packet's first quadlet (None: too short to carry one)."""
    return raw[3] >> 4 if len(raw) >= 4 else None


def _size(raw: bytes) -> tuple[int, int, bytes]:
    return (len(raw), sum(1 for byte in raw if byte), raw)


def _candidates(raw: bytes) -> Iterator[bytes]:
    """Simpler versions of ``raw``, most promising first."""
    found = header_of(raw)
    if found is not None:
        layout, fields = found
        size = 4 * layout.sealed_header.count
        present = len(raw) - size
        if layout.has_data and present > 4:
            half = present // 2 & ~3
            # Just the header; half the data under the old header and CRC; half the
            # data, sound.
            yield raw[:size]
            yield raw[: size + half] + raw[-4:]
            relengthed = with_header(raw[: size + half], {"data_length": half}, fix_crc=True)
            sound = recomputed_crcs(relengthed)
            if sound is not None:
                yield sound
        for name, value in fields.items():
            if name not in _KEEP and value:
                yield with_header(raw, {name: 0}, fix_crc=True)
                yield with_header(raw, {name: 0}, fix_crc=False)
    for quadlet in reversed(range(len(raw) // 4)):
        yield delete_quadlet(raw, quadlet)
    if len(raw) % 4:
        yield raw[: len(raw) // 4 * 4]
