"""``fw1394 dissect``, ``fw1394 capture`` and ``fw1394 wireshark-dissector`` as users run them."""

from __future__ import annotations

import csv
import io
import json
import re
import signal
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest
from polling import wait_until

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats import batch as batches
from fw1394.capture.formats import containers
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.cli import capture as capture_cli
from fw1394.cli.main import main


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("trace") / "sim.pcapng"
    write_trace(str(path), simulate(3000, Scenario(lost_every=97, busy_every=89, corrupt_every=61)))
    return path


def dissect(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    status = main(["dissect", *args])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


def test_packet_view(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = dissect(capsys, str(trace))
    lines = out.splitlines()
    assert status == 0 and len(lines) > 3000
    assert "bus reset, generation 2" in lines[0]
    assert any("read_block_response" in line and "ack_complete" in line for line in lines)
    assert any("data CRC error" in line for line in lines)


def test_verbose_packet_view_lists_every_field(
    trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, _ = dissect(capsys, str(trace), "-v", "--tcode", "read_quadlet_request")
    assert status == 0
    for field in ("destination_id", "tlabel", "retry", "offset", "header_crc_ok", "direction"):
        assert f"    {field}" in out


def test_transaction_view_json_and_filters(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = dissect(
        capsys, str(trace), "--transactions", "--json", "--node", "2", "--since", "0.01"
    )
    objects = [json.loads(line) for line in out.splitlines()]
    assert status == 0 and objects
    assert all(obj["responder"] & 0x3F == 2 or obj["requester"] & 0x3F == 2 for obj in objects)
    assert all(obj["time_s"] >= 0.01 for obj in objects)
    kinds = {obj["kind"] for obj in objects}
    assert {"split", "concatenated", "unified"} <= kinds
    assert any("no_response" in obj["flags"] for obj in objects)


def test_csv_outputs(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    for view in ("--view=packets", "--transactions"):
        status, out, _ = dissect(capsys, str(trace), view, "--csv", "--until", "0.002")
        rows = list(csv.reader(io.StringIO(out)))
        assert status == 0 and len(rows) > 2
        assert len({len(row) for row in rows}) == 1


def test_stats_view(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = dissect(capsys, str(trace), "--stats", "--json")
    report = json.loads(out)
    assert status == 0
    assert report["records_read"] >= 3000
    assert report["latency"]["p50_ns"] < report["latency"]["p99_ns"] <= report["latency"]["max_ns"]
    assert set(report["latency_by_node"]) == {"node 0", "node 1", "node 2", "node 3"}
    assert report["errors"]["no_response"] > 0 and report["errors"]["data CRC error"] > 0
    status, text, _ = dissect(capsys, str(trace), "-s")
    assert "latency by kind:" in text and "p99=" in text


def test_rom_view(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, out, _ = dissect(capsys, str(trace), "--rom")
    assert status == 0 and out.count("bus info block") == 4 and "text: 'QLA3'" in out


def test_plots(trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    pytest.importorskip("matplotlib")
    latency, size = tmp_path / "latency.png", tmp_path / "size.png"
    status, _, _ = dissect(
        capsys, str(trace), "-s", "--plot-latency", str(latency), "--plot-size", str(size)
    )
    assert status == 0
    for path in (latency, size):
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


@pytest.mark.parametrize(
    ("content", "message"),
    [
        (None, "no such file"),
        (b"", "empty"),
        (b"\x00\x01\x02\x03" * 50, "cannot tell the format"),
    ],
)
def test_bad_inputs_are_one_line_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes | None, message: str
) -> None:
    path = tmp_path / "input"
    if content is not None:
        path.write_bytes(content)
    status, out, err = dissect(capsys, str(path))
    assert status == 2 and not out
    assert len(err.splitlines()) == 1 and message in err


def test_bad_options_are_one_line_errors(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = dissect(capsys, str(trace), "--tcode", "frobnicate")
    assert status == 2 and "unknown tcode" in err and len(err.splitlines()) == 1


def test_truncated_trace_reports_and_keeps_going(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.pcapng"
    cut.write_bytes(trace.read_bytes()[:-7])
    status, out, err = dissect(capsys, str(cut), "-s", "--json")
    assert status == 2 and "truncated block" in err and "cut short" in err  # as tshark
    assert json.loads(out)["errors"]["unreadable_records"] == 1


class FakeTap:
    """Stands in for a bus tap: hands out records, then nothing."""

    def __init__(self, records: list[BusRecord]) -> None:
        self.records: Iterator[BusRecord] = iter(records)
        self.closed = False

    def receive(self, timeout: float) -> BusRecord | None:
        return next(self.records, None)

    def __enter__(self) -> FakeTap:
        return self

    def __exit__(self, *exc: object) -> None:
        self.closed = True

    def close(self) -> None:
        self.closed = True


def test_capture_from_a_tap(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    records = list(simulate(50))
    tap = FakeTap(records)
    monkeypatch.setattr(capture_cli, "_open_tap", lambda bus: tap)
    path = tmp_path / "tap.pcapng"
    status = main(["capture", "--bus", "x", "-w", str(path), "--count", str(len(records))])
    out, err = capsys.readouterr()
    assert status == 0 and tap.closed
    assert f"{len(records)} packets written" in err
    assert len(out.splitlines()) == len(records) and "self_id" in out
    with open(path, "rb") as stream:
        assert sum(len(chunk) for chunk in containers.read_chunks(stream)) == len(records)


def test_capture_stops_between_records_on_a_signal(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    class SlowTap(FakeTap):
        def receive(self, timeout: float) -> BusRecord | None:
            threading.Event().wait(min(timeout, 0.01))
            return next(self.records, None)

    tap = SlowTap(list(simulate(5000)))
    monkeypatch.setattr(capture_cli, "_open_tap", lambda bus: tap)
    stops = {}

    def stop_soon(stop: threading.Event) -> dict[int, object]:
        stops["event"] = stop
        threading.Timer(0.3, stop.set).start()
        return {}

    monkeypatch.setattr(capture_cli, "_stop_on_signals", stop_soon)
    path = tmp_path / "stopped.pcap"
    assert main(["capture", "-w", str(path), "-q"]) == 0
    with open(path, "rb") as stream:
        chunks = list(containers.read_chunks(stream))
    assert sum(len(c) for c in chunks) > 0 and not any(c.issues for c in chunks)


def test_capture_option_errors(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["capture", "--udp", "--bus", "b", "-w", "/tmp/never.pcapng"]) == 2
    assert "choose one" in capsys.readouterr().err


def test_wireshark_dissector_is_generated(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["wireshark-dissector"]) == 0
    lua = capsys.readouterr().out
    for needle in ('"fw1394.dst_id"', '"fw1394.src_id"', '"fw1394.tlabel"', '"fw1394.offset"',
                   '"fw1394.rcode"', '"fw1394.extended_tcode"', 'DissectorTable.get("udp.port")',
                   'DissectorTable.get("wtap_encap")'):  # fmt: skip
        assert needle in lua


@pytest.mark.process
@pytest.mark.slow
def test_capture_of_a_live_virtual_bus(tmp_path: Path, unique_bus_name: str) -> None:
    """The real tap on a real (loopback) virtual bus, driven by `fw1394 read`."""
    import subprocess
    import sys

    name = unique_bus_name

    def fw1394(*args: str, timeout: float = 30) -> subprocess.CompletedProcess[str]:
        command = [sys.executable, "-m", "fw1394.cli.main", *args]
        return subprocess.run(command, capture_output=True, text=True, timeout=timeout)

    up = fw1394("bus", "up", "--name", name, "--nodes", "2")
    if up.returncode != 0:
        pytest.skip(f"no virtual bus on this machine: {up.stderr.strip()[:200]}")
    path = tmp_path / "bus.pcapng"
    try:
        capture = subprocess.Popen(
            [sys.executable, "-m", "fw1394.cli.main", "capture", "--bus", name, "-w", str(path),
             "--duration", "60"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        )  # fmt: skip
        # The capture creates its output file once its tap has joined the bus.
        wait_until(lambda: path.exists() or capture.poll() is not None, timeout=30)
        for node in ("0", "1"):
            fw1394("read", "--name", name, node, "0xfffff0000400", timeout=10)
        capture.send_signal(signal.SIGINT)  # Ctrl-C: what it has is written
        out, err = capture.communicate(timeout=30)
    finally:
        fw1394("bus", "down", "--name", name)
    assert capture.returncode == 0, err
    assert "read_quadlet_request" in out and "packets written" in err
    result = fw1394("dissect", str(path), "--transactions")
    assert result.returncode == 0 and "QR 0xfffff0000400" in result.stdout


def test_count_counts_packets_and_keeps_the_last_ones_ack(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    records = list(simulate(60, Scenario(separate_acks=True)))
    is_ack = [r.record_type == RecordType.ack for r in records]
    # A packet whose ack follows it, well inside the trace: -c must not cut between them.
    last = next(i for i in range(20, len(records) - 1) if not is_ack[i] and is_ack[i + 1])
    count = is_ack[: last + 1].count(False)
    tap = FakeTap(records)
    monkeypatch.setattr(capture_cli, "_open_tap", lambda bus: tap)
    path = tmp_path / "counted.pcapng"
    argv = ["capture", "-i", "arm", "-w", str(path), "-c", str(count), "-t", "ud"]
    assert main(argv) == 0
    out, err = capsys.readouterr()
    assert f"{count} packets written" in err
    with open(path, "rb") as stream:
        written = [
            batch.record(i)
            for batch in map(batches.from_fw1394_chunk, containers.read_chunks(stream))
            for i in range(len(batch))
        ]
    assert written == records[: last + 2]  # the COUNTth packet, and its ack
    # -t ud: every line starts with a UTC date, as tshark -t ud prints it.
    assert all(
        re.match(r"\d{4}-\d\d-\d\d \d\d:\d\d:\d\d\.\d{9} g", line) for line in out.splitlines()
    )


def test_the_bus_is_named_by_name_bus_or_i(monkeypatch: pytest.MonkeyPatch) -> None:
    opened: list[str] = []

    def tap(bus: str) -> FakeTap:
        opened.append(bus)
        return FakeTap([])

    monkeypatch.setattr(capture_cli, "_open_tap", tap)
    for flag in ("--name", "--bus", "-i"):
        assert main(["capture", flag, "arm", "-w", "/dev/null", "--duration", "0.01", "-q"]) == 0
    assert opened == ["arm", "arm", "arm"]
