"""The command table of ``fw1394.cli.main``: one command builds only its own module's parsers.

``COMMANDS`` names, for each command, the module that registers it; the checks
here register every module on its own and hold the table to what they add, and
show that a parser built for one command is the one the full parser holds.
"""

from __future__ import annotations

import argparse
import importlib
import subprocess
import sys

import pytest

from fw1394.cli.main import COMMANDS, OneLineParser, build_parser, command_modules


def _registered_by(module_name: str) -> set[str]:
    parser = OneLineParser(prog="fw1394")
    subparsers = parser.add_subparsers(dest="command")
    register = getattr(importlib.import_module(f"fw1394.cli.{module_name}"), "register", None)
    if register is not None:
        register(subparsers)
    return set(subparsers.choices)


def _commands(parser: argparse.ArgumentParser) -> dict[str, argparse.ArgumentParser]:
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            return dict(action.choices)
    raise AssertionError("no subcommands")


def test_the_table_names_every_command_with_the_module_that_registers_it() -> None:
    registered = {
        command: module for module in command_modules() for command in _registered_by(module)
    }
    assert registered == COMMANDS


@pytest.mark.parametrize("command", sorted(COMMANDS))
def test_one_command_builds_only_its_module_and_the_same_parser(command: str) -> None:
    alone = _commands(build_parser(command))
    assert set(alone) == _registered_by(COMMANDS[command])
    full = _commands(build_parser())
    assert alone[command].format_help() == full[command].format_help()


def test_a_word_that_names_no_command_builds_them_all() -> None:
    assert set(_commands(build_parser("no-such-command"))) == set(COMMANDS)
    assert set(_commands(build_parser(None))) == set(COMMANDS)


@pytest.mark.process
def test_running_one_command_imports_no_other_command() -> None:
    # A fresh interpreter: this one has imported every command already.
    code = (
        "import sys\n"
        "from fw1394.cli.main import main\n"
        "try:\n"
        "    main(['encode', '--help'])\n"
        "except SystemExit:\n"
        "    pass\n"
        "print(sorted(m for m in sys.modules if m.startswith(('fw1394.cli.', 'numpy'))))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.splitlines()[-1] == str(
        ["fw1394.cli.codec", "fw1394.cli.common", "fw1394.cli.main"]
    )
