"""The ``fw1394`` command: one entry point, one subcommand per module of this package.

Every module in :mod:`fw1394.cli` that defines ``register(subparsers)`` adds its
subcommands; a subcommand's handler takes the parsed namespace and returns an
exit status. Every error the library raises on purpose derives from
:class:`fw1394.Error`; :func:`main` prints any of them as one line on stderr and
exits with status 2, here and nowhere else, so commands let them propagate;
an :class:`OSError` that reaches it (a file, a socket, a permission) is one
line and status 2 as well. :class:`~fw1394.cli.common.CliError` remains for
what only the command line can get wrong (options that do not go together).
"""

from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING, Any, NoReturn

from fw1394.cli.common import fail, reported_write_errors
from fw1394.errors import Error
from fw1394.version import __version__

if TYPE_CHECKING:
    from _typeshed import SupportsWrite

DESCRIPTION = """\
fw1394: a wire-level IEEE 1394 (FireWire) protocol toolkit.

Decode and encode packets, run a virtual 1394 bus of emulated FPGA boards,
drive them as a host, capture and dissect traffic, and fuzz a node's parser.
Run `fw1394 COMMAND --help` for each command's options and examples.
"""


class OneLineParser(argparse.ArgumentParser):
    """A parser whose errors are one line on stderr (exit 2), not a usage block.

    Subparsers are made of the parser's own class, so every subcommand and
    sub-subcommand reports its errors the same way.
    """

    def error(self, message: str) -> NoReturn:
        text = " ".join(message.split())
        self.exit(2, f"{self.prog}: error: {text} (see {self.prog} --help)\n")

    def _print_message(self, message: str, file: SupportsWrite[str] | None = None) -> None:
        # argparse drops a failed write of --help silently; let it reach the
        # command's write-error report instead.
        if message:
            (file or sys.stderr).write(message)

    def add_subparsers(self, **kwargs: Any) -> Any:
        kwargs.setdefault("parser_class", SubcommandParser)
        return super().add_subparsers(**kwargs)


class SubcommandParser(OneLineParser):
    """A subcommand's parser: it reports its own unknown arguments, naming itself."""

    def parse_known_args(  # type: ignore[override]
        self, args: Sequence[str] | None = None, namespace: argparse.Namespace | None = None
    ) -> tuple[argparse.Namespace, list[str]]:
        parsed, extras = super().parse_known_args(args, namespace)
        if extras:
            self.error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed, extras


#: The module of this package that registers each command. Running one command
#: builds only that module's parsers, so it imports only what that command
#: needs (``dissect`` alone pulls in numpy); ``--help``, ``--version`` and a
#: word that names no command build them all. A test holds this table to what
#: the modules register.
COMMANDS = {
    "bench": "bench",
    "bus": "bus",
    "capture": "capture",
    "decode": "codec",
    "demo": "demo",
    "dissect": "dissect",
    "encode": "codec",
    "fuzz": "fuzz",
    "jhu": "jhu",
    "libraw1394": "raw1394",
    "lock": "host",
    "lsnodes": "lsnodes",
    "node": "bus",
    "read": "host",
    "run": "raw1394",
    "send": "send",
    "watch": "watch",
    "wireshark-dissector": "wireshark",
    "write": "host",
}


def command_modules() -> list[str]:
    """Every module of this package that may register commands, in name order."""
    package = importlib.import_module("fw1394.cli")
    names = (info.name for info in pkgutil.iter_modules(package.__path__))
    return sorted(name for name in names if name not in ("main", "common"))


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``fw1394`` parser: with every command, or only the module that registers ``command``."""
    parser = OneLineParser(
        prog="fw1394",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"fw1394 {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    home = COMMANDS.get(command or "")
    for name in [home] if home else command_modules():
        module = importlib.import_module(f"fw1394.cli.{name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    words = sys.argv[1:] if argv is None else list(argv)
    parser = build_parser(words[0] if words else None)
    try:
        with reported_write_errors():
            args = parser.parse_args(words)
            if args.command is None:
                parser.print_help()
                return 0
            status: int = args.handler(args)
    except Error as error:
        return fail(" ".join(str(error).split()) or type(error).__name__)
    except KeyboardInterrupt:
        print("fw1394: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # Output piped into `head` and closed: not an error worth a traceback.
        return 0
    except OSError as error:
        # The environment said no (a file, a socket, a permission): the user can act on it.
        return fail(os_error_line(error))
    return status


def os_error_line(error: OSError) -> str:
    """``PATH: reason`` as the shell's own tools say it, or the reason alone."""
    reason = error.strerror or str(error) or type(error).__name__
    if error.filename is not None:
        return f"{error.filename}: {reason}"
    return " ".join(reason.split())


if __name__ == "__main__":
    sys.exit(main())
