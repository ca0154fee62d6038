"""tshark-style plumbing of ``dissect`` and ``capture``: pipes, -r, -c, -t, no silent nothing."""

from __future__ import annotations

import io
import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Sequence
from pathlib import Path

import pytest

from fw1394.capture.analysis.sample_traces import write_eth1394_sample
from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats import containers
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.cli import capture as capture_cli
from fw1394.cli.main import main

DATA = Path(__file__).parent.parent / "data"
TSHARK = shutil.which("tshark")
#: The sample exchange's first datagram, as written by write_eth1394_sample.
SAMPLE_START_NS = 1_700_000_000_000_000_000


def fw1394(
    *argv: str, stdin: bytes | None = None, timeout: float = 60
) -> subprocess.CompletedProcess[bytes]:
    return subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", *argv],
        input=stdin,
        capture_output=True,
        timeout=timeout,
    )


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plumbing") / "sim.pcapng"
    write_trace(str(path), simulate(2000, Scenario(lost_every=97, busy_every=89)))
    return path


@pytest.fixture(scope="module")
def sample(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("plumbing") / "eth1394.pcap"
    write_eth1394_sample(str(path))
    return path


def dissect(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    status = main(["dissect", *argv])
    captured = capsys.readouterr()
    return status, captured.out, captured.err


# -- standard input and -r ------------------------------------------------------------------
@pytest.mark.parametrize("view", [[], ["--transactions"], ["--stats", "--json"]])
@pytest.mark.process
def test_stdin_gives_what_the_file_gives(trace: Path, view: list[str]) -> None:
    from_file = fw1394("dissect", str(trace), *view)
    from_pipe = fw1394("dissect", "-", *view, stdin=trace.read_bytes())
    from_r = fw1394("dissect", "-r", "-", *view, stdin=trace.read_bytes())
    assert from_file.returncode == from_pipe.returncode == from_r.returncode == 0
    assert from_pipe.stdout == from_r.stdout
    if view == ["--transactions"]:
        # A transaction is shown when it ends, so its place among those that end in
        # the same stretch of input depends on how the input was cut into reads.
        assert sorted(from_pipe.stdout.splitlines()) == sorted(from_file.stdout.splitlines())
    else:
        assert from_pipe.stdout == from_file.stdout
    assert len(from_file.stdout) > 1000


@pytest.mark.parametrize("name", ["firewire-tracepoints.txt", "firewire-ohci-dmesg.txt"])
@pytest.mark.process
def test_stdin_detects_kernel_text(name: str) -> None:
    path = DATA / name
    from_file = fw1394("dissect", str(path))
    from_pipe = fw1394("dissect", "-", stdin=path.read_bytes())
    named = fw1394("dissect", "-", "--format", "kernel", stdin=path.read_bytes())
    assert from_file.returncode == 0 and from_pipe.stdout == from_file.stdout != b""
    assert named.stdout == from_file.stdout


def test_r_option_and_positional_agree(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert dissect(capsys, "-r", str(trace), "-c", "50") == dissect(capsys, str(trace), "-c", "50")
    status, out, err = dissect(capsys, str(trace), "-r", str(trace))
    assert status == 2 and out == "" and "give one" in err


@pytest.mark.process
def test_empty_stdin_is_an_error() -> None:
    result = fw1394("dissect", "-", stdin=b"")
    assert (
        result.returncode == 2 and b"standard input" in result.stderr and b"empty" in result.stderr
    )


# -- -c ---------------------------------------------------------------------------------------
def test_count_reads_only_count_records(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, everything, _ = dissect(capsys, str(trace))
    status, first, _ = dissect(capsys, str(trace), "-c", "37")
    assert status == 0 and first.splitlines() == everything.splitlines()[:37]
    _, stats, _ = dissect(capsys, str(trace), "--stats", "--json", "-c", "100")
    assert json.loads(stats)["records_read"] == 100
    # The transactions of the first 300 records are those of a trace cut after them.
    cut = trace.parent / "first-300.pcapng"
    records = list(simulate(2000, Scenario(lost_every=97, busy_every=89)))[:300]
    write_trace(str(cut), records)
    _, counted, _ = dissect(capsys, str(trace), "--transactions", "--json", "-c", "300")
    _, truth, _ = dissect(capsys, str(cut), "--transactions", "--json")
    assert counted == truth and len(truth.splitlines()) > 20


def test_count_applies_before_the_filter(trace: Path, capsys: pytest.CaptureFixture[str]) -> None:
    """As tshark -r -c: COUNT records are read, then filtered."""
    _, first, _ = dissect(capsys, str(trace), "-c", "200")
    _, filtered, _ = dissect(capsys, str(trace), "-c", "200", "-Y", "tcode == read_quadlet_request")
    assert filtered.splitlines() == [
        line for line in first.splitlines() if " read_quadlet_request " in line
    ]
    assert filtered


# -- -t ---------------------------------------------------------------------------------------
def time_column(line: str) -> str:
    return line[9:].split("  g")[0].strip()


def test_time_formats(sample: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, default, _ = dissect(capsys, str(sample))
    _, relative, _ = dissect(capsys, str(sample), "-t", "r")
    assert default == relative
    assert [time_column(line) for line in relative.splitlines()] == [
        f"{i * 0.0001:.9f}" for i in range(6)
    ]
    _, delta, _ = dissect(capsys, str(sample), "-t", "d")
    assert [time_column(line) for line in delta.splitlines()] == ["0.000000000"] + [
        "0.000100000"
    ] * 5
    _, shown_delta, _ = dissect(capsys, str(sample), "-t", "dd", "-Y", "frame == 1 || frame == 4")
    assert [time_column(line) for line in shown_delta.splitlines()] == [
        "0.000000000",
        "0.000300000",
    ]
    _, read_delta, _ = dissect(capsys, str(sample), "-t", "d", "-Y", "frame == 1 || frame == 4")
    assert [time_column(line) for line in read_delta.splitlines()] == ["0.000000000", "0.000100000"]
    _, epoch, _ = dissect(capsys, str(sample), "-t", "e", "-c", "2")
    assert [time_column(line) for line in epoch.splitlines()] == [
        "1700000000.000000000", "1700000000.000100000"
    ]  # fmt: skip
    _, utc, _ = dissect(capsys, str(sample), "-t", "ud", "-c", "2")
    assert [time_column(line) for line in utc.splitlines()] == [
        "2023-11-14 22:13:20.000000000", "2023-11-14 22:13:20.000100000"
    ]  # fmt: skip
    _, tx, _ = dissect(capsys, str(sample), "--transactions", "-t", "u")
    assert [time_column(line) for line in tx.splitlines()][:2] == [
        "22:13:20.000000000",
        "22:13:20.000200000",
    ]


# -- no silent nothing ------------------------------------------------------------------------
def test_eth1394_on_another_port_says_which(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "other-port.pcap"
    write_eth1394_sample(str(path), port=11394)
    status, out, err = dissect(capsys, str(path))
    assert status == 2 and out == ""
    assert "0 Eth1394 datagrams found on UDP port 1394" in err and "--port 11394" in err
    status, out, _ = dissect(capsys, str(path), "--port", "11394")
    assert status == 0 and "read_quadlet_request" in out


def test_kernel_format_on_random_bytes(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    path = tmp_path / "random.bin"
    path.write_bytes(os.urandom(4096))
    status, out, err = dissect(capsys, "--format", "kernel", str(path))
    assert status == 2 and out == ""
    assert "nothing recognised" in err and len(err.splitlines()) == 1


@pytest.mark.process
def test_cut_short_pcapng_exits_like_tshark(trace: Path, tmp_path: Path) -> None:
    cut = tmp_path / "cut.pcapng"
    whole = trace.read_bytes()
    cut.write_bytes(whole[: len(whole) - 37])
    ours = fw1394("dissect", str(cut))
    full = fw1394("dissect", str(trace))
    assert ours.returncode == 2 and b"cut short" in ours.stderr
    # Everything before the cut is still shown.
    assert ours.stdout.splitlines() == full.stdout.splitlines()[: len(ours.stdout.splitlines())]
    assert len(ours.stdout.splitlines()) == len(full.stdout.splitlines()) - 1
    if TSHARK is not None:
        theirs = subprocess.run([TSHARK, "-r", str(cut)], capture_output=True, timeout=60)
        assert theirs.returncode == ours.returncode
        assert len(theirs.stdout.splitlines()) == len(ours.stdout.splitlines())


def test_directory_and_missing_inputs(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    status, _, err = dissect(capsys, str(tmp_path))
    assert status == 2 and "is a directory" in err
    status, _, err = dissect(capsys, str(tmp_path / "none.pcapng"))
    assert status == 2 and "no such file" in err
    status, _, err = dissect(capsys)
    assert status == 2 and "no trace given" in err


@pytest.mark.process
def test_capture_of_a_bus_that_is_not_running() -> None:
    started = time.monotonic()
    result = fw1394("capture", "--bus", f"nosuchbus{os.getpid()}", "-w", "-")
    assert result.returncode == 2 and result.stdout == b""
    (line,) = result.stderr.decode().splitlines()
    assert "no bus" in line and "is running" in line and "fw1394 bus up" in line
    assert time.monotonic() - started < 30


@pytest.mark.process
def test_capture_refuses_a_directory(tmp_path: Path) -> None:
    result = fw1394("capture", "-w", str(tmp_path))
    assert result.returncode == 2 and b"is a directory" in result.stderr


@pytest.mark.process
def test_demo_refuses_a_directory_for_its_capture(tmp_path: Path) -> None:
    started = time.monotonic()
    result = fw1394("demo", "--capture", str(tmp_path), "--no-plot")
    assert result.returncode == 2 and result.stdout == b""
    assert b"is a directory" in result.stderr and len(result.stderr.splitlines()) == 1
    assert time.monotonic() - started < 20  # refused before the demo's bus starts


# -- capture -w - -----------------------------------------------------------------------------
class ListTap:
    def __init__(self, records: Sequence[object]) -> None:
        self.records = iter(records)

    def receive(self, timeout: float) -> object:
        return next(self.records, None)

    def __enter__(self) -> ListTap:
        return self

    def __exit__(self, *exc: object) -> None:
        pass

    def close(self) -> None:
        pass


def test_capture_to_stdout_writes_only_the_trace(
    monkeypatch: pytest.MonkeyPatch, capsysbinary: pytest.CaptureFixture[bytes]
) -> None:
    records = list(simulate(300))
    monkeypatch.setattr(capture_cli, "_open_tap", lambda bus: ListTap(records))
    assert main(["capture", "-w", "-", "-c", str(len(records))]) == 0
    captured = capsysbinary.readouterr()
    chunks = list(containers.read_chunks(io.BytesIO(captured.out)))
    assert sum(len(c) for c in chunks) == len(records) and not any(c.issues for c in chunks)
    assert b"written to standard output" in captured.err


@pytest.mark.process
@pytest.mark.slow
def test_live_bus_piped_into_dissect_and_tshark(tmp_path: Path) -> None:
    name = f"pipe{os.getpid()}"
    up = fw1394("bus", "up", "--name", name, "--nodes", "2", timeout=90)
    if up.returncode != 0:
        pytest.skip(f"no virtual bus on this machine: {up.stderr.decode()[:200]}")
    try:
        capture = subprocess.Popen(
            [sys.executable, "-m", "fw1394.cli.main", "capture", "--bus", name, "-w", "-",
             "--duration", "60"],
            stdout=subprocess.PIPE, stderr=subprocess.PIPE,
        )  # fmt: skip
        # The file header comes out as soon as the capture's tap listens.
        assert capture.stdout is not None
        head = os.read(capture.stdout.fileno(), 65536)
        for node in ("0", "1"):
            fw1394("read", "--name", name, node, "0xfffff0000400", timeout=20)
        capture.send_signal(signal.SIGINT)  # Ctrl-C: what it has is written
        rest, err = capture.communicate(timeout=60)
        trace = head + rest
    finally:
        fw1394("bus", "down", "--name", name)
    assert capture.returncode == 0, err
    shown = fw1394("dissect", "-", "-Y", "tcode == read_quadlet_request", stdin=trace)
    assert shown.returncode == 0, shown.stderr
    assert shown.stdout.count(b"read_quadlet_request") >= 2
    if TSHARK is None:
        return
    lua = tmp_path / "fw1394.lua"
    lua.write_bytes(fw1394("wireshark-dissector").stdout)
    theirs = subprocess.run(
        [TSHARK, "-X", f"lua_script:{lua}", "-r", "-", "-Y", "fw1394.tcode == 4",
         "-T", "fields", "-e", "fw1394.offset"],
        input=trace, capture_output=True, timeout=60,
    )  # fmt: skip
    assert theirs.returncode == 0, theirs.stderr
    assert len(theirs.stdout.splitlines()) == shown.stdout.count(b"read_quadlet_request")


def test_plot_paths_are_checked_before_reading(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = dissect(capsys, str(trace), "--plot-latency", str(tmp_path))
    assert status == 2 and out == "" and "is a directory" in err
    missing = tmp_path / "no" / "such" / "dir" / "p.png"
    status, out, err = dissect(capsys, str(trace), "--plot-size", str(missing))
    assert status == 2 and out == "" and "does not exist" in err


def test_count_stops_before_a_cut(
    trace: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.pcapng"
    whole = trace.read_bytes()
    cut.write_bytes(whole[: len(whole) - 37])
    status, out, err = dissect(capsys, str(cut), "-c", "10", "--threads", "1")
    assert status == 0 and len(out.splitlines()) == 10 and err == ""
