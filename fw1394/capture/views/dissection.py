"""``fw1394 dissect``: read a trace, decode, pair, count, and print the chosen view.

Batches flow through one pipeline whatever the input format. The numpy
work of decoding a batch runs on worker threads (numpy releases the GIL),
while the main thread pairs and prints the previous one.
"""

from __future__ import annotations

import contextlib
import csv
import json
import queue
import threading
from collections import deque
from collections.abc import Callable, Iterator, Mapping
from concurrent.futures import Future, ThreadPoolExecutor
from dataclasses import dataclass, field
from typing import Any, TextIO

import numpy as np

from fw1394.capture.analysis.columns import Decoded, decode
from fw1394.capture.analysis.rom_collect import RomCollector
from fw1394.capture.analysis.rom_decode import report_lines
from fw1394.capture.analysis.stats import Stats
from fw1394.capture.analysis.transactions import Pairer, Transactions
from fw1394.capture.formats import sources
from fw1394.capture.formats.batch import Batch
from fw1394.capture.formats.record import RecordType
from fw1394.capture.views.filter_columns import Links, packet_columns, transaction_columns
from fw1394.capture.views.packet_view import PACKET_CSV, PacketFormatter
from fw1394.capture.views.time_format import TimeColumn, previous_times, splice
from fw1394.capture.views.transaction_view import TRANSACTION_CSV, TransactionFormatter
from fw1394.packets.nodeid import PHY_ID_MASK

VIEWS = ("packets", "transactions", "stats", "rom")
#: Malformed-record messages printed before the rest are only counted.
MAX_ISSUES_SHOWN = 50
#: A display filter: which rows of the named columns to keep.
RowFilter = Callable[[Mapping[str, tuple[np.ndarray, ...]], int], np.ndarray]


@dataclass
class Options:
    view: str = "packets"
    output: str = "text"  # text, json or csv
    verbose: bool = False
    nodes: frozenset[int] = frozenset()
    tcodes: frozenset[int] = frozenset()
    since_s: float | None = None
    until_s: float | None = None
    verify_crc: bool | None = None
    workers: int = 2
    want_plots: bool = False
    display_filter: RowFilter | None = None
    #: Read only this many records (as ``tshark -r -c``), whatever the view.
    count: int | None = None
    time_format: str = "r"
    #: The whole trace's pairing, for packet filters on request_in, latency ... (see pair_links)
    links: Links | None = None
    #: ``output == "fields"`` (tshark -T fields): these Wireshark field names, joined by this.
    fields: tuple[str, ...] = ()
    separator: str = "\t"
    hex_dump: bool = False  # -x: each packet's bytes after its line
    flush_each: bool = False  # -l: flush after every packet
    #: -w: the packets shown go to this trace writer instead of being printed.
    writer: Any = None
    #: -z: statistics printed at the end (expert, conv, latency); -q: no packet rows.
    statistics: tuple[str, ...] = ()
    quiet: bool = False


@dataclass
class Outcome:
    stats: Stats
    roms: RomCollector
    records: int = 0
    issues: int = 0
    issue_lines: list[str] = field(default_factory=list)
    shown: int = 0  # rows printed by the packet or transaction view
    cut_short: bool = False  # the input ended in the middle of a record
    nodes_seen: set[int] = field(default_factory=set)  # PHY IDs, kept when rows are chosen
    duration_s: float | None = None  # first to last record


def decoded_batches(
    jobs: Iterator[sources.Job], verify_crc: bool | None, workers: int
) -> Iterator[tuple[Batch, Decoded]]:
    """Run each job and decode its batch, in order, with up to ``workers`` batches ahead.

    With workers, reading the input runs on a thread of its own, decoding on
    a pool, and the caller pairs and prints: three stages that overlap.
    """

    def work(job: sources.Job) -> tuple[Batch, Decoded]:
        batch = job()
        return batch, decode(batch, verify_crc)

    if workers <= 1:
        for job in jobs:
            yield work(job)
        return
    ahead: queue.Queue[Future[tuple[Batch, Decoded]] | BaseException | None]
    ahead = queue.Queue(maxsize=workers + 1)
    stop = threading.Event()
    with ThreadPoolExecutor(max_workers=workers) as pool:

        def produce() -> None:
            try:
                for job in jobs:
                    if stop.is_set():
                        break
                    ahead.put(pool.submit(work, job))
            except BaseException as error:  # handed to the consumer, which re-raises it
                ahead.put(error)
            ahead.put(None)

        reader = threading.Thread(target=produce, name="fw1394-reader", daemon=True)
        reader.start()
        try:
            while (item := ahead.get()) is not None:
                if isinstance(item, BaseException):
                    raise item
                yield item.result()
        finally:
            stop.set()
            while reader.is_alive():
                with contextlib.suppress(queue.Empty):
                    ahead.get(timeout=0.05)
            reader.join()


def pair_links(jobs: Iterator[sources.Job], verify_crc: bool | None, workers: int) -> Links:
    """A first pass over a trace that pairs every transaction, so that a packet
    filter knows a request's response frame before it reaches it (tshark's
    two passes do the same)."""
    pairer = Pairer()
    ended: list[Transactions] = []
    last_frame = 0
    for batch, decoded in decoded_batches(jobs, verify_crc, workers):
        if len(batch):
            last_frame = max(last_frame, int(batch.frame.max()))
        ended.extend(pairer.feed(batch, decoded))
    ended.extend(pairer.finish())
    return Links.of(ended, last_frame)


class Dissection:
    """One run of the pipeline over one input."""

    def __init__(self, options: Options, out: TextIO) -> None:
        self.options = options
        self.out = out
        self.pairer = Pairer()
        self.outcome = Outcome(Stats(), RomCollector())
        self.origin_ns: int | None = None
        self.ordinal = 0
        self._csv = csv.writer(out) if options.output == "csv" else None
        self._generation: int | None = None
        self.time_column = TimeColumn(options.time_format)
        self._last_ts: int | None = None  # the last record of the previous batch
        self._ack_owed = False  # -w: the last packet saved waits for its ack record
        view = options.view
        self.pairs = view in ("transactions", "stats", "rom") or options.want_plots
        self.pairs |= bool(options.statistics)
        self._conversations: dict[tuple[int, int], int] = {}
        if self._csv is not None and view == "packets":
            self._csv.writerow(PACKET_CSV)
        elif self._csv is not None and view == "transactions":
            self._csv.writerow(TRANSACTION_CSV)

    def run(self, jobs: Iterator[sources.Job]) -> Outcome:
        options = self.options
        for batch, decoded in decoded_batches(jobs, options.verify_crc, options.workers):
            self.feed(batch, decoded)
            if self.full:
                break
        if self.pairs:
            self._transactions(self.pairer.finish(), None)
        self.finish()
        return self.outcome

    @property
    def full(self) -> bool:
        """``count`` records read: nothing more is."""
        return self.options.count is not None and self.outcome.records >= self.options.count

    # -- per batch --------------------------------------------------------------------------
    def feed(self, batch: Batch, decoded: Decoded) -> None:
        outcome = self.outcome
        count = self.options.count
        if count is not None:
            room = count - outcome.records
            if len(batch) > room:
                # Problems past the last record read are not this reading's (tshark: same).
                limit = int(batch.position[room])
                first = np.arange(len(batch)) < room
                batch, decoded = batch.select(first), decoded.select(first)
                batch.issues = [issue for issue in batch.issues if issue.position < limit]
        for issue in batch.issues:
            outcome.cut_short |= bool(getattr(issue, "cut_short", False))
            outcome.issues += 1
            if len(outcome.issue_lines) < MAX_ISSUES_SHOWN:
                outcome.issue_lines.append(str(issue))
        if not len(batch):
            return
        if self.origin_ns is None:
            self.origin_ns = int(batch.ts_ns[0])
        outcome.records += len(batch)
        if self.selecting:
            self._note_span(batch, decoded)
        keep = self._packet_filter(batch, decoded)
        if self.options.view == "stats" or self.options.statistics:
            outcome.stats.add_batch(batch, decoded, keep)
        if "conv" in self.options.statistics:
            self._count_conversations(decoded, keep)
        if self.options.view == "packets" and not self.options.quiet:
            self._packets(batch, decoded, keep)
        elif self.options.view == "packets":
            self.outcome.shown += int(np.count_nonzero(keep))
        if self.pairs:
            self._transactions(self.pairer.feed(batch, decoded), batch)
        self.ordinal += len(batch)
        self._last_ts = int(batch.ts_ns[-1])

    def _note_span(self, batch: Batch, decoded: Decoded) -> None:
        """What an empty selection's message names: the nodes and time the trace holds."""
        for column in (decoded.fields["source_id"], decoded.fields["destination_id"]):
            ids = column[column >= 0] & PHY_ID_MASK
            self.outcome.nodes_seen.update(int(n) for n in np.unique(ids) if n != PHY_ID_MASK)
        self.outcome.duration_s = (int(batch.ts_ns[-1]) - (self.origin_ns or 0)) / 1e9

    def _packet_filter(self, batch: Batch, decoded: Decoded) -> np.ndarray:
        o = self.options
        keep = np.ones(len(batch), bool)
        if o.since_s is not None or o.until_s is not None:
            seconds = (batch.ts_ns - (self.origin_ns or 0)) / 1e9
            if o.since_s is not None:
                keep &= seconds >= o.since_s
            if o.until_s is not None:
                keep &= seconds <= o.until_s
        if o.tcodes:
            keep &= np.isin(decoded.tcode, list(o.tcodes))
        if o.nodes:
            ids = list(o.nodes)
            source, destination = decoded.fields["source_id"], decoded.fields["destination_id"]
            keep &= (
                np.isin(source, ids)
                | np.isin(destination, ids)
                | np.isin(source & PHY_ID_MASK, ids) & (source >= 0)
                | np.isin(destination & PHY_ID_MASK, ids) & (destination >= 0)
                | np.isin(batch.sender, ids)
            )
        if o.display_filter is not None and o.view == "packets" and keep.any():
            columns = packet_columns(batch, decoded, self.origin_ns or 0, o.links)
            keep &= o.display_filter(columns, len(batch))
        return keep

    def _transaction_filter(self, tx: Transactions) -> np.ndarray:
        o = self.options
        keep = np.ones(len(tx), bool)
        if o.since_s is not None or o.until_s is not None:
            seconds = (tx["first_ts"] - (self.origin_ns or 0)) / 1e9
            if o.since_s is not None:
                keep &= seconds >= o.since_s
            if o.until_s is not None:
                keep &= seconds <= o.until_s
        if o.tcodes:
            wanted = list(o.tcodes)
            keep &= np.isin(tx["tcode"], wanted) | np.isin(tx["resp_tcode"], wanted)
        if o.nodes:
            ids = list(o.nodes)
            requester, responder = tx["requester"], tx["responder"]
            keep &= (
                np.isin(requester, ids)
                | np.isin(responder, ids)
                | np.isin(requester & PHY_ID_MASK, ids)
                | np.isin(responder & PHY_ID_MASK, ids)
            )
        if o.display_filter is not None and keep.any():
            columns = transaction_columns(tx, self.origin_ns or 0)
            keep &= o.display_filter(columns, len(tx))
        return keep

    def _packets(self, batch: Batch, decoded: Decoded, keep: np.ndarray) -> None:
        if self.options.writer is not None:
            self._save(batch, keep)
            return
        if self.options.output == "fields":
            self._fields(batch, decoded, keep)
            return
        formatter = PacketFormatter(batch, decoded, self.origin_ns or 0)
        write: Callable[[str], object] = self.out.write
        output = self.options.output
        rows = np.flatnonzero(keep)
        self.outcome.shown += len(rows)
        if self.options.hex_dump or self.options.flush_each:
            write = self._decorated(batch, write)
        retimed = output == "text" and self.options.time_format != "r"
        if retimed:
            previous = previous_times(batch.ts_ns, self._last_ts)
            unknown = batch.flag("time_unknown")
        for row in rows.tolist():
            if retimed:
                line = formatter.line(row)
                if not unknown[row]:
                    before = int(previous[row])
                    stamp = self.time_column.text(
                        int(batch.ts_ns[row]), self.origin_ns or 0, None if before < 0 else before
                    )
                    line = splice(line, int(batch.frame[row]), stamp)
                write(line + "\n")
                if self.options.verbose:
                    write("\n".join(formatter.details(row)) + "\n")
            elif output == "json":
                write(json.dumps(formatter.json(row, self.options.verbose)) + "\n")
            elif self._csv is not None:
                self._csv.writerow(formatter.csv(row))
            else:
                write(formatter.line(row) + "\n")
                if self.options.verbose:
                    write("\n".join(formatter.details(row)) + "\n")

    def _decorated(self, batch: Batch, write: Callable[[str], object]) -> Callable[[str], None]:
        """``write`` with -x (a frame's bytes after its line: the pseudo-header and the
        packet, as tshark shows a frame of this link type) and -l (flush each line).

        Every row's output ends in one call per packet line; the dump follows the
        line of the frame that it starts with."""
        from fw1394.capture.formats.trace_writer import record_bytes

        frames = {int(f): r for r, f in enumerate(batch.frame.tolist())}
        options, out = self.options, self.out

        def decorated(text: str) -> None:
            write(text)
            if options.hex_dump:
                head = text.split(None, 1)
                row = frames.get(int(head[0])) if head and head[0].isdigit() else None
                if row is not None:
                    write(hex_dump(record_bytes(batch.record(row))) + "\n")
            if options.flush_each:
                out.flush()

        return decorated

    def _fields(self, batch: Batch, decoded: Decoded, keep: np.ndarray) -> None:
        """tshark -T fields: the named fields of each packet shown, absent ones empty."""
        from fw1394.capture.views.display_filter import field_name

        columns = packet_columns(batch, decoded, self.origin_ns or 0, self.options.links)
        names = [field_name(name) or name for name in self.options.fields]
        values = [columns[name] for name in names]
        rows = np.flatnonzero(keep)
        self.outcome.shown += len(rows)
        separator = self.options.separator
        for row in rows.tolist():
            cells = [
                field_text(name, column, row) for name, column in zip(names, values, strict=True)
            ]
            self.out.write(separator.join(cells) + "\n")
            if self.options.flush_each:
                self.out.flush()

    def _save(self, batch: Batch, keep: np.ndarray) -> None:
        """-w: write the packets that passed, each with the ack record right after it."""
        from fw1394.capture.formats.trace_writer import write_record

        is_ack = batch.record_type == RecordType.ack
        after = np.zeros(len(batch), bool)
        after[1:] = keep[:-1] & ~is_ack[:-1] & is_ack[1:]
        if len(batch) and self._ack_owed and is_ack[0]:
            after[0] = True
        self._ack_owed = bool(len(batch)) and bool(keep[-1]) and not bool(is_ack[-1])
        self.outcome.shown += int(np.count_nonzero(keep))
        for row in np.flatnonzero(keep | after).tolist():
            write_record(self.options.writer, batch.record(row))

    def _transactions(self, ended: list[Transactions], batch: Batch | None) -> None:
        """Account for, and in the transaction view print, what ended in one batch."""
        rows: list[tuple[int, TransactionFormatter, int]] = []
        for tx in ended:
            if batch is not None and self.options.view == "rom":
                self.outcome.roms.add(tx, batch)
            if not len(tx):
                continue
            keep = self._transaction_filter(tx)
            if self.options.view == "stats" or self.options.want_plots or self.options.statistics:
                self.outcome.stats.add_transactions(tx, keep)
            if self.options.view == "transactions":
                formatter = TransactionFormatter(tx, self.origin_ns or 0)
                first = tx["first_ordinal"]
                rows.extend((int(first[r]), formatter, r) for r in np.flatnonzero(keep).tolist())
        if self.options.view != "transactions":
            return
        resets = self._resets(batch)
        rows.sort(key=lambda item: item[0])
        for ordinal, formatter, row in rows:
            while resets and resets[0][0] < ordinal:
                self._reset_line(resets.popleft())
            self._transaction_row(formatter, row)
        while resets:
            self._reset_line(resets.popleft())

    @property
    def selecting(self) -> bool:
        """Rows are chosen (-Y, --node, --tcode, --since, --until), not all shown."""
        o = self.options
        chosen = (o.display_filter, o.since_s, o.until_s)
        return bool(o.nodes or o.tcodes) or any(value is not None for value in chosen)

    def _resets(self, batch: Batch | None) -> deque[tuple[int, int, int]]:
        # A chosen view shows what matched; a generation change among the
        # matches still gets its own separator line (_transaction_row).
        if batch is None or self.options.output != "text" or self.selecting:
            return deque()
        rows = np.flatnonzero(batch.record_type == RecordType.bus_reset)
        return deque(
            (self.ordinal + int(r), int(batch.frame[r]), int(batch.generation[r]))
            for r in rows.tolist()
        )

    def _reset_line(self, reset: tuple[int, int, int]) -> None:
        _, frame, generation = reset
        self.out.write(f"{frame:>7}  ---- bus reset: generation {generation} ----\n")
        self._generation = generation

    def _transaction_row(self, formatter: TransactionFormatter, row: int) -> None:
        self.outcome.shown += 1
        if self.options.output == "json":
            self.out.write(json.dumps(formatter.json(row)) + "\n")
            return
        if self._csv is not None:
            self._csv.writerow(formatter.csv(row))
            return
        generation = formatter.value("generation", row)
        if self._generation is not None and generation != self._generation:
            self.out.write(f"{'':>7}  ---- generation {generation} ----\n")
        self._generation = generation
        line = formatter.line(row)
        if self.options.time_format != "r" and formatter.value("time_known", row) != 0:
            first_ts = formatter.value("first_ts", row)
            stamp = self.time_column.text(first_ts, self.origin_ns or 0)
            line = splice(line, formatter.value("first_frame", row), stamp)
        self.out.write(line + "\n")

    def _count_conversations(self, decoded: Decoded, keep: np.ndarray) -> None:
        source, destination = decoded.fields["source_id"], decoded.fields["destination_id"]
        rows = keep & (decoded.tcode >= 0) & (source >= 0) & (destination >= 0)
        pairs, counts = np.unique(
            np.stack([source[rows], destination[rows]], axis=1), axis=0, return_counts=True
        )
        for (a, b), n in zip(pairs.tolist(), counts.tolist(), strict=True):
            self._conversations[(a, b)] = self._conversations.get((a, b), 0) + n

    def _statistics(self) -> None:
        """-z: each statistic asked for, in the order asked, after the packets."""
        self.outcome.stats.issues = self.outcome.issues
        report = self.outcome.stats.report()
        rule = "=" * 72
        for name in self.options.statistics:
            lines = [rule]
            if name == "expert":
                lines.append("Expert information: problems and notes")
                lines += [
                    line
                    for line in stats_lines(
                        {"errors": report.get("errors"), "notes": report.get("notes")}
                    )
                    if not line.startswith(("records read", "bus resets"))
                ]
            elif name == "conv":
                lines.append("Conversations: packets from a node to a node")
                for (a, b), n in sorted(self._conversations.items(), key=lambda item: -item[1]):
                    lines.append(f"  {a:04x} -> {b:04x}  {n:8d}")
            else:
                lines.append("Transaction latency (request to response)")
                lines += [
                    line
                    for line in stats_lines(
                        {
                            "latency": report.get("latency"),
                            "latency_by_kind": report.get("latency_by_kind"),
                            "latency_by_node": report.get("latency_by_node"),
                        }
                    )
                    if not line.startswith(("records read", "bus resets"))
                ]
            lines.append(rule)
            self.out.write("\n".join(lines) + "\n")

    # -- end ---------------------------------------------------------------------------------
    def finish(self) -> None:
        if self.options.statistics:
            self._statistics()
        view, output = self.options.view, self.options.output
        if view == "stats":
            self.outcome.stats.issues = self.outcome.issues
            report = self.outcome.stats.report()
            report["records_read"] = self.outcome.records
            if output == "json":
                self.out.write(json.dumps(report) + "\n")
            else:
                self.out.write("\n".join(stats_lines(report)) + "\n")
        elif view == "rom":
            for node, generation, rom in self.outcome.roms.reports():
                if output == "json":
                    obj = {"node": node, "generation": generation, "bus_info": rom.bus_info}
                    obj["bus_info_crc_ok"] = rom.bus_info_crc_ok
                    obj["blocks"] = [vars(block) for block in rom.blocks]
                    obj["missing"] = rom.missing
                    self.out.write(json.dumps(obj) + "\n")
                else:
                    self.out.write(f"node {node:04x}, generation {generation}:\n")
                    self.out.write("".join(f"  {line}\n" for line in report_lines(rom)))
            if not self.outcome.roms.roms and output == "text":
                self.out.write("no configuration ROM reads in this trace\n")


#: Fields tshark -T fields prints in hex (base.HEX in the Lua dissector).
HEX_FIELDS = frozenset(
    {"src", "dst", "offset", "quadlet_data", "header_crc", "data_crc", "phy.check", "ack_parity"}
)


def field_text(name: str, column: tuple[Any, ...], row: int) -> str:
    """One -T fields cell: empty where absent; several values comma-separated."""
    cells = []
    for values in column:
        value = values[row]
        if value is None or (not isinstance(value, str | bytes) and value < 0):
            continue
        if isinstance(value, bytes):
            cells.append(value.hex())
        elif isinstance(value, str):
            cells.append(value)
        elif name in ("time", "latency"):
            cells.append(f"{int(value) / 1e9:.9f}")
        elif name in HEX_FIELDS:
            cells.append(
                f"0x{int(value):0{12 if name == 'offset' else 4 if name in ('src', 'dst') else 8}x}"
            )
        else:
            cells.append(str(int(value)))
    return ",".join(cells)


def hex_dump(data: bytes) -> str:
    """tshark -x: offset, 16 bytes in hex, and their printable characters."""
    lines = []
    for at in range(0, len(data), 16):
        chunk = data[at : at + 16]
        octets = " ".join(f"{b:02x}" for b in chunk)
        text = "".join(chr(b) if 32 <= b < 127 else "." for b in chunk)
        lines.append(f"{at:04x}  {octets:<47}   {text}")
    return "\n".join(lines) + "\n"


def stats_lines(report: dict[str, object]) -> list[str]:
    """The stats report as aligned text."""
    lines: list[str] = []

    def section(title: str, values: object) -> None:
        if not isinstance(values, dict) or not values:
            return
        lines.append(f"{title}:")
        for key, value in values.items():
            if isinstance(value, dict):
                lines.append(f"  {key:<28} {_latency_text(value)}")
            else:
                lines.append(f"  {key:<28} {value}")

    lines.append(f"records read: {report.get('records_read')}")
    duration = report.get("duration_s")
    if isinstance(duration, float):
        lines.append(f"duration: {duration:.6f} s")
    lines.append(f"bus resets: {report.get('bus_resets')}")
    for title in ("records", "tcodes", "acks", "rcodes", "transactions"):
        section(title, report.get(title))
    latency = report.get("latency")
    if isinstance(latency, dict):
        lines.append(f"latency (all): {_latency_text(latency)}")
    section("latency by kind", report.get("latency_by_kind"))
    section("latency by node", report.get("latency_by_node"))
    section("errors", report.get("errors"))
    section("notes", report.get("notes"))
    return lines


def _latency_text(values: dict[str, object]) -> str:
    def us(name: str) -> str:
        value = values.get(name)
        return "-" if not isinstance(value, int) else f"{value / 1000:.3f}"

    return (
        f"n={values.get('count')} p50={us('p50_ns')} p90={us('p90_ns')} "
        f"p99={us('p99_ns')} max={us('max_ns')} us"
    )
