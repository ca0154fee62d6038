"""Linux kernel text: firewire tracepoints and firewire-ohci debug lines, mixed freely.

Lines are read one at a time (bounded memory); anything that is not a
firewire line is skipped, a firewire line that cannot be understood becomes
an :class:`Issue` with its line number. Times come from the ftrace
timestamp, else from a dmesg ``[ seconds]`` prefix; a log with neither has
records in order but no clock (latencies are then unknown).

An outbound request's ack arrives on a later ``..._outbound_complete`` line,
so records wait in a short queue until their ack is known (or the queue
moves on without it).
"""

from __future__ import annotations

import re
import struct
from collections import deque
from collections.abc import Iterator
from dataclasses import replace
from typing import TextIO

from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import kernel_ohci, kernel_trace
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.containers import Issue
from fw1394.capture.formats.record import BusRecord, RecordType

DMESG_TIME = re.compile(r"^\s*\[\s*(\d+)\.(\d+)\]")
BATCH_RECORDS = 20_000
#: Lines an outbound record waits for its completion before it goes without an ack.
PATIENCE = 512


def looks_like_kernel_text(head: str) -> bool:
    return "firewire" in head or bool(kernel_ohci.PACKET.search(head)) or "selfIDs" in head


class _Pending:
    __slots__ = ("line", "ready", "record")

    def __init__(self, record: BusRecord, line: int, ready: bool) -> None:
        self.record, self.line, self.ready = record, line, ready


class KernelTextReader:
    def __init__(self, stream: TextIO, little_endian: bool = True) -> None:
        self._stream = stream
        self._little_endian = little_endian
        self._ohci = kernel_ohci.OhciState()
        self._queue: deque[_Pending] = deque()
        self._waiting: dict[str, _Pending] = {}
        self._self_id_generations: set[int] = set()
        self._order = 0

    def batches(self, batch_records: int = BATCH_RECORDS) -> Iterator[Batch]:
        records: list[BusRecord] = []
        lines: list[int] = []
        issues: list[Issue] = []
        for number, line in enumerate(self._stream, start=1):
            try:
                self._line(line, number)
            except (ValueError, KeyError, IndexError, OverflowError, struct.error) as error:
                issues.append(Issue(number, f"firewire line not understood: {error}", "line"))
            self._drain(records, lines, number, final=False)
            if len(records) >= batch_records:
                yield batches.from_records(records, lines, lines, issues, unit="line")
                records, lines, issues = [], [], []
        self._drain(records, lines, 0, final=True)
        if records or issues:
            yield batches.from_records(records, lines, lines, issues, unit="line")

    def _time(self, line: str, traced_ns: int | None) -> tuple[int, bool]:
        if traced_ns is not None:
            return traced_ns, True
        match = DMESG_TIME.match(line)
        if match:
            return kernel_trace.nanoseconds(match[1], match[2]), True
        self._order += 1
        return self._order, False

    def _add(self, record: BusRecord, number: int, ready: bool = True) -> _Pending:
        entry = _Pending(record, number, ready)
        self._queue.append(entry)
        return entry

    def _line(self, line: str, number: int) -> None:
        event = kernel_trace.parse(line, self._little_endian)
        if event is not None:
            self._trace(event, number)
            return
        time_ns, known = self._time(line, None)
        if "A" not in line and "selfID" not in line:
            return
        records = kernel_ohci.parse(line, time_ns, self._ohci)
        for record in records or []:
            self._add(record if known else replace(record, time_known=False), number)

    def _trace(self, event: kernel_trace.TraceEvent, number: int) -> None:
        if event.name in kernel_trace.COMPLETE_EVENTS:
            entry = self._waiting.pop(event.transaction or "", None)
            if entry is not None and event.status is not None:
                ack = kernel_trace.ack_of_status(event.status)
                entry.record, entry.ready = replace(entry.record, ack=ack), True
            return
        if event.name == "bus_reset_handle":
            self._self_id_generations = {event.records[0].generation}
        elif event.name == "self_id_sequence":
            # bus_reset_handle already listed every self-ID of this generation.
            generation = int(event.fields.get("generation", "0"), 0)
            if generation in self._self_id_generations:
                return
        for record in event.records:
            waits = event.name.endswith("outbound_initiate") and event.transaction is not None
            entry = self._add(record, number, ready=not waits)
            if waits and event.transaction is not None:
                self._waiting[event.transaction] = entry

    def _drain(self, records: list[BusRecord], lines: list[int], number: int, final: bool) -> None:
        queue = self._queue
        while queue and (queue[0].ready or final or number - queue[0].line > PATIENCE):
            entry = queue.popleft()
            if not entry.ready:
                self._waiting = {k: v for k, v in self._waiting.items() if v is not entry}
            records.append(entry.record)
            lines.append(entry.line)


def read_batches(stream: TextIO) -> Iterator[Batch]:
    return KernelTextReader(stream).batches()


__all__ = ["KernelTextReader", "RecordType", "looks_like_kernel_text", "read_batches"]
