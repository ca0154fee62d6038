"""Terminal output through rich: the demo's status line, the CLI's tables, fuzz progress.

On a terminal (a pseudo-terminal here) rich draws them; a pipe or file gets the
plain text it always got.
"""

from __future__ import annotations

import fcntl
import io
import os
import pty
import re
import struct
import sys
import termios
from collections.abc import Callable
from types import SimpleNamespace

import pytest

from fw1394.cli import demo
from fw1394.cli.common import print_table
from fw1394.progress import Progress

ESCAPE = re.compile(r"\x1b\[[0-9;?]*[A-Za-z]")
ROWS = [("node", "kind", "generation"), ("0", "snake2010", "3"), ("12", "qla1", "3")]


def on_terminal(
    monkeypatch: pytest.MonkeyPatch, stream_name: str, draw: Callable[[], None], columns: int = 120
) -> str:
    """What ``draw`` writes to sys.<stream_name> when that is a terminal."""
    monkeypatch.setenv("TERM", "xterm-256color")
    monkeypatch.delenv("NO_COLOR", raising=False)
    monkeypatch.setenv("COLUMNS", str(columns))  # rich sizes from fds 0-2, which are not this
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, columns, 0, 0))
    with os.fdopen(slave, "w", encoding="utf-8") as stream:
        monkeypatch.setattr(sys, stream_name, stream)
        draw()
        stream.flush()
    chunks = []
    while True:
        try:
            chunk = os.read(master, 65536)
        except OSError:
            break
        if not chunk:
            break
        chunks.append(chunk)
    os.close(master)
    return b"".join(chunks).decode("utf-8", "replace").replace("\r\n", "\n")


def result(overruns: int, trips: int) -> SimpleNamespace:
    return SimpleNamespace(
        cycles=1234, overruns=overruns, watchdog_trips=trips, final_errors=[-12.0, 40.0, 3.0]
    )


def test_demo_status_line_redraws_in_place(monkeypatch: pytest.MonkeyPatch) -> None:
    def draw() -> None:
        demo._progress(result(0, 0), 1.5)
        demo._progress(result(2, 0), 2.25)

    shown = on_terminal(monkeypatch, "stderr", draw)
    assert "\n" not in shown  # one line, drawn over
    assert shown.count("\x1b[2K") == 2  # erased before each redraw
    assert ESCAPE.sub("", shown) == (
        "  t= 1.50 s  cycles=  1234  overruns=   0  |error|max=     40 counts  watchdog trips=0"
        "  t= 2.25 s  cycles=  1234  overruns=   2  |error|max=     40 counts  watchdog trips=0"
    )
    second = shown[shown.rindex("\x1b[2K") :]
    assert re.search(r"\x1b\[1;31moverruns=   2\x1b\[0m", second)  # overruns in bold red


def test_demo_status_line_is_cut_to_the_window_not_wrapped(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    shown = on_terminal(monkeypatch, "stderr", lambda: demo._progress(result(0, 1), 1.5), 60)
    text = ESCAPE.sub("", shown)
    assert "\n" not in shown and len(text) == 60
    assert text.startswith("  t= 1.50 s  cycles=  1234  overruns=   0")


def test_tables_stay_plain_for_pipes(capsys: pytest.CaptureFixture[str]) -> None:
    print_table(ROWS)
    assert capsys.readouterr().out == (
        "  node  kind       generation\n  0     snake2010  3\n  12    qla1       3\n"
    )


def test_tables_on_a_terminal_are_aligned_by_rich(monkeypatch: pytest.MonkeyPatch) -> None:
    shown = on_terminal(monkeypatch, "stdout", lambda: print_table(ROWS, indent="  "))
    lines = [line.rstrip() for line in ESCAPE.sub("", shown).splitlines()]
    assert lines == [
        "  node  kind       generation",
        "  0     snake2010  3",
        "  12    qla1       3",
    ]


def test_rich_markup_in_a_cell_is_printed_as_is(monkeypatch: pytest.MonkeyPatch) -> None:
    rows = [("offset", "[bold]0x400[/bold]"), ("name", "[config ROM+0x0]")]
    shown = on_terminal(monkeypatch, "stdout", lambda: print_table(rows, indent=""))
    lines = [line.rstrip() for line in ESCAPE.sub("", shown).splitlines()]
    assert lines == ["offset  [bold]0x400[/bold]", "name    [config ROM+0x0]"]


def fuzz_session(progress: Progress) -> None:
    progress.start("fuzzing", 256)
    for cases in (0, 64, 128):
        progress.update(cases, "cases, 900/s, 1 findings", force=True)
    progress.finish("stopped: max-cases")


def test_fuzz_progress_is_a_rich_bar_on_a_terminal(monkeypatch: pytest.MonkeyPatch) -> None:
    shown = on_terminal(monkeypatch, "stderr", lambda: fuzz_session(Progress()))
    plain = ESCAPE.sub("", shown)
    assert "━" in shown and "#" not in plain  # rich's bar, not a hand-drawn one
    assert re.search(r"50%\s+128/256 cases, 900/s, 1 findings", plain)
    assert re.search(r"fuzzing: done in \d+\.\d s; stopped: max-cases", plain)


def test_fuzz_progress_stays_plain_in_a_pipe() -> None:
    stream = io.StringIO()
    fuzz_session(Progress(stream))
    lines = stream.getvalue().splitlines()
    assert [line.split(" (")[0] for line in lines[:-1]] == [
        "fuzzing: 0/256",
        "fuzzing: 64/256",
        "fuzzing: 128/256",
    ]
    assert "25%" in lines[1] and lines[1].endswith("cases, 900/s, 1 findings")
    assert lines[-1].startswith("fuzzing: done in ") and "\x1b" not in stream.getvalue()
