"""Every subcommand, its output sent to /dev/full: one line on stderr, exit 2, no traceback.

/dev/full fails every write with ENOSPC, as a full disk does. Output goes there
both block-buffered (the failure comes at the final flush) and line-buffered
(the failure comes at the first line; argparse would swallow it for --help).
The commands that need a bus run as processes against a real one.
"""

from __future__ import annotations

import argparse
import errno
import io
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.capture.analysis.traffic_sim import Scenario, simulate
from fw1394.capture.formats.trace_writer import write_trace
from fw1394.cli.main import build_parser, main

FULL = "fw1394: error: cannot write standard output: No space left on device"


def subcommands(
    parser: argparse.ArgumentParser, path: tuple[str, ...] = ()
) -> Iterator[tuple[str, ...]]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield (*path, name)
                yield from subcommands(sub, (*path, name))


ALL = sorted(subcommands(build_parser()))


@pytest.fixture(scope="module")
def trace(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("trace") / "bus.pcapng"
    write_trace(str(path), simulate(300, Scenario(busy_every=13, lost_every=17)))
    return path


def run_into_full(
    argv: list[str], capsys: pytest.CaptureFixture[str], line_buffered: bool
) -> tuple[int, str]:
    """``main(argv)`` with standard output on /dev/full; its status and stderr."""
    saved_out, saved_in = sys.stdout, sys.stdin
    sys.stdout = open("/dev/full", "w", buffering=1 if line_buffered else -1)  # noqa: SIM115
    sys.stdin = io.StringIO("")
    try:
        try:
            status = main(argv)
        except SystemExit as leaving:
            status = int(leaving.code or 0)
    finally:
        full, sys.stdout, sys.stdin = sys.stdout, saved_out, saved_in
        try:
            full.close()
        except OSError as error:  # anything left in its buffer fails once more
            assert error.errno == errno.ENOSPC
    return status, capsys.readouterr().err


def test_every_subcommand_is_listed() -> None:
    names = {path[0] for path in ALL}
    assert {"decode", "encode", "dissect", "capture", "bus", "fuzz", "jhu", "demo"} <= names
    assert ("fuzz", "run") in ALL and ("bus", "status") in ALL


@pytest.mark.parametrize("line_buffered", [False, True], ids=["buffered", "line"])
@pytest.mark.parametrize("path", [(), *ALL], ids=lambda p: " ".join(p) or "fw1394")
def test_help_of_every_subcommand(
    path: tuple[str, ...], line_buffered: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    status, err = run_into_full([*path, "--help"], capsys, line_buffered)
    assert (status, err) == (2, FULL + "\n")


def offline(trace: Path, findings: Path) -> list[list[str]]:
    t = str(trace)
    return [
        ["--version"],
        ["decode", "ffc0f140", "ffc1ffff", "f0000984", "5bdd119c"],
        ["decode", "--json", "ffc0f140", "ffc1ffff", "f0000984", "5bdd119c"],
        ["decode", "--jhu", "0105", "ffc01c40", "ffd00000", "00000004", "a9927b79"],
        ["encode", "read_quadlet_request", "--destination-id", "0xffc0", "--offset", "0x0"],
        ["encode", "write_response", "--rcode", "resp_address_error", "--json"],
        ["dissect", t],
        ["dissect", t, "-v"],
        ["dissect", t, "--json"],
        ["dissect", t, "--csv"],
        ["dissect", t, "--transactions"],
        ["dissect", t, "--stats"],
        ["dissect", t, "--stats", "--json"],
        ["dissect", t, "--rom"],
        ["wireshark-dissector"],
        ["fuzz", "defects"],
        ["fuzz", "run", "inproc:memory", "--max-cases", "20", "--findings", str(findings)],
    ]


@pytest.mark.parametrize("line_buffered", [False, True], ids=["buffered", "line"])
def test_offline_commands(
    trace: Path, tmp_path: Path, line_buffered: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    for number, argv in enumerate(offline(trace, tmp_path / "findings")):
        if argv[:2] == ["fuzz", "run"]:
            argv = [*argv[:-1], f"{argv[-1]}-{number}"]
        status, err = run_into_full(argv, capsys, line_buffered)
        assert (status, err) == (2, FULL + "\n"), argv


@pytest.mark.process
def test_a_closed_pipe_ends_quietly(trace: Path) -> None:
    """`| head`: the reader asked for no more; no traceback, no error line (as tshark)."""
    command = [sys.executable, "-m", "fw1394.cli.main", "dissect", str(trace), "-v"]
    with subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE) as process:
        assert process.stdout is not None and process.stderr is not None
        process.stdout.read(10)
        process.stdout.close()  # the reader goes away, as `| head -c 10` does
        err = process.stderr.read().decode()
        status = process.wait(timeout=60)
    assert (status, err) == (0, "")


@pytest.fixture(scope="module")
def bus() -> Iterator[AdapterBus]:
    with adapter_bus("full", 2, board="snake2010,memory") as launched:
        yield launched


ON_A_BUS = [
    ["bus", "status"],
    ["bus", "status", "--json"],
    ["lsnodes"],
    ["lsnodes", "--json"],
    ["read", "0", "0x0"],
    ["read", "1", "0x0", "--json"],
    ["write", "1", "0x0", "0x5"],
    ["send", "ffc00440", "ffc20000", "00000000", "fac9b467"],
    ["capture", "-w", "-", "--duration", "1"],
]


@pytest.mark.process
@pytest.mark.parametrize("argv", ON_A_BUS, ids=" ".join)
def test_commands_on_a_bus(bus: AdapterBus, argv: list[str]) -> None:
    with open("/dev/full", "w") as full:
        result = subprocess.run(
            [sys.executable, "-m", "fw1394.cli.main", *argv, "--name", bus.name],
            stdout=full,
            stderr=subprocess.PIPE,
            text=True,
            timeout=60,
            env=bus.cli_env(),
            stdin=subprocess.DEVNULL,
        )
    assert (result.returncode, result.stderr) == (2, FULL + "\n"), argv
