"""Phase progress of ``fw1394 bench``: a rich bar on a terminal, the same plain lines elsewhere."""

from __future__ import annotations

import fcntl
import io
import os
import pty
import re
import struct
import termios

import pytest

from fw1394.progress import Progress


def run_phase(progress: Progress) -> None:
    progress.start("quadlet reads", 200)
    for done in range(201):
        progress.update(done)
    progress.note("bands at 31 and 62 us")
    progress.finish("mean 40.0 us")


def test_plain_lines_when_not_a_terminal() -> None:
    stream = io.StringIO()
    run_phase(Progress(stream))
    lines = stream.getvalue().splitlines()
    shares = [
        re.fullmatch(r"quadlet reads: (\d+)/200 \((\d+)%, \d+\.\d s\)", line) for line in lines[:4]
    ]
    assert [(m.group(1), m.group(2)) for m in shares if m] == [
        ("0", "0"), ("50", "25"), ("100", "50"), ("150", "75"),
    ]  # fmt: skip
    assert lines[4] == "bands at 31 and 62 us"
    assert re.fullmatch(r"quadlet reads: done in \d+\.\d s; mean 40\.0 us", lines[5])
    assert len(lines) == 6 and "\033" not in stream.getvalue()


def test_disabled_writes_nothing() -> None:
    stream = io.StringIO()
    run_phase(Progress(stream, enabled=False))
    assert stream.getvalue() == ""


def test_a_terminal_gets_a_bar_then_the_summary_line() -> None:
    master, slave = pty.openpty()
    fcntl.ioctl(slave, termios.TIOCSWINSZ, struct.pack("HHHH", 24, 100, 0, 0))
    with os.fdopen(slave, "w", encoding="utf-8") as stream:
        run_phase(Progress(stream))
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
    shown = b"".join(chunks).decode("utf-8", "replace")
    assert "━" in shown  # rich's bar
    assert "200/200" in shown
    assert "bands at 31 and 62 us" in shown
    plain = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", shown)
    assert re.search(r"quadlet reads: done in \d+\.\d s; mean 40\.0 us", plain)


def test_the_bar_leaves_stdout_alone(capfd: pytest.CaptureFixture[str]) -> None:
    master, slave = pty.openpty()
    with os.fdopen(slave, "w", encoding="utf-8") as stream:
        progress = Progress(stream)
        progress.start("block writes", 10)
        print("a result line", flush=True)  # printed by the run while the bar shows
        progress.finish()
    os.close(master)
    assert capfd.readouterr().out == "a result line\n"
