"""Every parse error of every subcommand is one line on stderr and exit status 2."""

from __future__ import annotations

import argparse
import subprocess
import sys

import pytest

from fw1394.cli.main import build_parser, main


def every_parser() -> list[tuple[list[str], argparse.ArgumentParser]]:
    """(words, parser) of the top level, every subcommand and every sub-subcommand."""
    found: list[tuple[list[str], argparse.ArgumentParser]] = []

    def walk(words: list[str], parser: argparse.ArgumentParser) -> None:
        found.append((words, parser))
        for action in parser._actions:
            if isinstance(action, argparse._SubParsersAction):
                for name, child in action.choices.items():
                    walk([*words, name], child)

    walk([], build_parser())
    # Aliases are the same parser under another name: keep one of each.
    unique: dict[int, tuple[list[str], argparse.ArgumentParser]] = {}
    for words, parser in found:
        unique.setdefault(id(parser), (words, parser))
    return list(unique.values())


PARSERS = every_parser()


def one_line_failure(capsys: pytest.CaptureFixture[str], argv: list[str]) -> str:
    with pytest.raises(SystemExit) as caught:
        main(argv)
    captured = capsys.readouterr()
    assert caught.value.code == 2, argv
    assert captured.out == "", argv
    lines = captured.err.splitlines()
    assert len(lines) == 1, (argv, captured.err)
    return lines[0]


def test_there_are_many_subcommands() -> None:
    assert len(PARSERS) > 30


@pytest.mark.parametrize("words", [w for w, _ in PARSERS], ids=lambda w: " ".join(w) or "fw1394")
def test_an_unknown_option_is_one_line(
    words: list[str], capsys: pytest.CaptureFixture[str]
) -> None:
    line = one_line_failure(capsys, [*words, "--no-such-option"])
    prog = " ".join(["fw1394", *words])
    assert line.startswith(f"{prog}: error: ")
    assert "--no-such-option" in line or "required" in line
    assert f"(see {prog} --help)" in line


@pytest.mark.parametrize(
    ("argv", "blamed"),
    [
        (["read", "0", "xyz"], "OFFSET: 'xyz' is not a number"),
        (["encode"], "required: KIND"),
        (["encode", "ack", "--parity", "99"], "--parity: 99 (0x63) does not fit in 4 bits"),
        (["encode", "write_response", "--rcode", "resp_nonsense"], "--rcode"),
        (["encode", "read_quadlet_request", "--tlabel", "64"], "--tlabel: 64 (0x40) does not fit"),
        (["dissect", "x.pcapng", "-t", "q"], "-t/--time-format"),
        (["dissect", "x.pcapng", "-c", "0"], "-c/--count: '0' is not above zero"),
        (["capture"], "required: -w/--write"),
        (["nosuch"], "invalid choice: 'nosuch'"),
        (["bus", "up", "--nodes", "many"], "--nodes"),
    ],
)
def test_errors_name_the_argument(
    argv: list[str], blamed: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert blamed in one_line_failure(capsys, argv)


@pytest.mark.process
def test_parse_error_through_the_real_entry_point() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", "read", "0", "xyz"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr.splitlines() == [
        "fw1394 read: error: argument OFFSET: 'xyz' is not a number (use 123 or 0x7b) "
        "(see fw1394 read --help)"
    ]
