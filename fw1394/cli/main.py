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


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="fw1394",
        description=DESCRIPTION,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("--version", action="version", version=f"fw1394 {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    package = importlib.import_module("fw1394.cli")
    for module_info in sorted(pkgutil.iter_modules(package.__path__), key=lambda m: m.name):
        if module_info.name in ("main", "common"):
            continue
        module = importlib.import_module(f"fw1394.cli.{module_info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(subparsers)
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    parser = build_parser()
    try:
        with reported_write_errors():
            args = parser.parse_args(argv)
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
