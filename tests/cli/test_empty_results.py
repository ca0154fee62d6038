"""No silent nothing: an empty result says what was empty and why, and a request
that cannot be met (an unknown plot format, --since after --until) is a one-line
error before any work."""

from __future__ import annotations

import io
import subprocess
import sys
from pathlib import Path

import pytest

from fw1394.capture.analysis.traffic_sim import simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.cli.main import main


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    # simulate(): a bus reset, then self-IDs of PHYs 0..4 and their transactions.
    path = tmp_path_factory.mktemp("trace") / "bus.pcapng"
    write_trace(str(path), simulate(200))
    return path


def run(
    argv: list[str], capsys: pytest.CaptureFixture[str], stdin: str = ""
) -> tuple[int, str, str]:
    saved = sys.stdin
    sys.stdin = io.StringIO(stdin)
    try:
        status = main(argv)
    except SystemExit as leaving:
        status = int(leaving.code or 0)
    finally:
        sys.stdin = saved
    out, err = capsys.readouterr()
    return status, out, err


@pytest.mark.parametrize("flags", [[], ["--jhu"], ["--json"]])
@pytest.mark.parametrize("stdin", ["", "\n\n", "# only a comment\n"])
def test_decode_of_nothing_says_so(
    flags: list[str], stdin: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(["decode", *flags], capsys, stdin)
    assert status == 2 and out == ""
    assert len(err.splitlines()) == 1 and "standard input" in err and "empty" in err


@pytest.mark.parametrize("view", [[], ["--transactions"]])
@pytest.mark.parametrize("node", ["5", "99"])
def test_a_node_not_in_the_trace_is_named_with_the_nodes_that_are(
    trace: Path, view: list[str], node: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(["dissect", str(trace), *view, "--node", node], capsys)
    assert status == 0 and out == ""
    assert f"matched --node {node}" in err
    assert "nodes in it: 0 (0xffc0), 1 (0xffc1), 2 (0xffc2), 3 (0xffc3), 4 (0xffc4)" in err


def test_a_time_window_past_the_end_says_how_long_the_trace_is(
    trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(["dissect", str(trace), "--since", "5"], capsys)
    assert status == 0 and out == ""
    assert "no record matched --since 5" in err and "spanning 0.00" in err


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--node", "-3"], "--node -3 is not a node"),
        (["--node", "0x10000"], "is not a node"),
        (["--since", "5", "--until", "1"], "--since 5 is after --until 1"),
        (["--since", "-1"], "--since -1"),
        (["--plot-latency", "x.txt"], "cannot draw a .txt file"),
        (["--plot-size", "plot"], "cannot draw a file without an extension"),
    ],
)
def test_impossible_requests_are_one_line_errors(
    trace: Path, argv: list[str], message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, err = run(["dissect", str(trace), *argv], capsys)
    assert status == 2 and out == ""
    assert len(err.splitlines()) == 1 and message in err and err.startswith("fw1394: error: ")


def test_a_filtered_transaction_view_prints_only_what_matched(
    trace: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status, out, _ = run(["dissect", str(trace), "--transactions", "--json"], capsys)
    everything = out.count("\n")
    status, out, _ = run(["dissect", str(trace), "--transactions", "--node", "2"], capsys)
    lines = out.splitlines()
    assert status == 0 and 0 < len(lines) < everything
    assert not [line for line in lines if "bus reset" in line]
    assert all("ffc2" in line for line in lines if "----" not in line)


@pytest.mark.process
def test_regdocs_without_a_document_says_how_to_call_it() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "fw1394.boards.regdocs"], capture_output=True, text=True, timeout=60
    )
    assert result.returncode == 2 and result.stdout == ""
    assert "no document named" in result.stderr and "docs/boards/*.md" in result.stderr


@pytest.mark.process
def test_regdocs_says_what_it_found(tmp_path: Path) -> None:
    plain = tmp_path / "plain.md"
    plain.write_text("# no tables here\n")
    result = subprocess.run(
        [sys.executable, "-m", "fw1394.boards.regdocs", str(plain)],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 0 and "no register tables" in result.stdout
    assert plain.read_text() == "# no tables here\n"


def test_a_report_that_found_nothing_is_no_finding_to_protect(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    findings = tmp_path / "findings"
    argv = ["fuzz", "run", "inproc:memory", "--max-cases", "30", "--findings", str(findings)]
    assert main(argv) == 0
    assert '"findings": []' in (findings / "report.json").read_text()
    capsys.readouterr()
    assert main(argv) == 0  # a second run may write over an empty report
    # A report that lists findings is protected, as before.
    report = findings / "report.json"
    report.write_text(report.read_text().replace('"findings": []', '"findings": [{"x": 1}]'))
    assert main(argv) == 2
    assert "already holds findings" in capsys.readouterr().err
