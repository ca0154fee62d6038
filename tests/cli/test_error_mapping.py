"""The command line maps errors in one place: commands do not re-wrap them.

:func:`fw1394.cli.main.main` prints any :class:`fw1394.Error` (and an
:class:`OSError`) as one line and exits with status 2, so a command that
catches a library error only to raise :class:`~fw1394.cli.common.CliError`
with the same text is noise, and one that catches ``Exception`` hides bugs.
The check reads the source of ``fw1394/cli`` and resolves what each
``except`` clause catches, including names imported inside functions.
"""

from __future__ import annotations

import ast
import builtins
import errno
import importlib
import inspect
from collections.abc import Iterator
from pathlib import Path

import pytest

import fw1394
from fw1394.cli import main as cli_main

CLI = Path(fw1394.__file__).parent / "cli"


def _imported_names(tree: ast.Module) -> dict[str, object]:
    """Every name an import statement of the module binds, anywhere in it."""
    names: dict[str, object] = {}
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.module == "_typeshed":
            continue  # typing only: no module at run time, and no exception
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            module = importlib.import_module(node.module)
            for alias in node.names:
                value = getattr(module, alias.name, None)
                if value is None:  # a submodule: from fw1394.capture.formats import live
                    value = importlib.import_module(f"{node.module}.{alias.name}")
                names[alias.asname or alias.name] = value
        elif isinstance(node, ast.Import):
            for alias in node.names:
                bound = alias.asname or alias.name.partition(".")[0]
                names[bound] = importlib.import_module(alias.name if alias.asname else bound)
    return names


def _caught(expression: ast.expr | None, names: dict[str, object]) -> Iterator[object]:
    """The objects an ``except`` clause names (None for a bare ``except:``)."""
    if expression is None:
        yield BaseException
        return
    if isinstance(expression, ast.Tuple):
        for element in expression.elts:
            yield from _caught(element, names)
        return
    if isinstance(expression, ast.Name):
        yield names.get(expression.id, getattr(builtins, expression.id, None))
        return
    if isinstance(expression, ast.Attribute):
        base = list(_caught(expression.value, names))
        yield getattr(base[0], expression.attr, None) if base else None
        return
    yield None  # a call (port_errors()) or other expression: unknown, so suspect


def _raises_new(handler: ast.ExceptHandler) -> list[ast.Raise]:
    return [n for n in ast.walk(handler) if isinstance(n, ast.Raise) and n.exc is not None]


def _raised_name(node: ast.Raise) -> str:
    call = node.exc.func if isinstance(node.exc, ast.Call) else node.exc
    return ast.unparse(call) if call is not None else ""


def rewraps(path: Path) -> list[str]:
    """``file:line what`` for every handler in ``path`` that re-wraps or catches all."""
    tree = ast.parse(path.read_text(), str(path))
    names = _imported_names(tree)
    found = []
    for handler in (n for n in ast.walk(tree) if isinstance(n, ast.ExceptHandler)):
        raised = _raises_new(handler)
        if not raised:
            continue  # clean-up and re-raise, or handled: not a re-wrap
        where = f"{path.name}:{handler.lineno}"
        for caught in _caught(handler.type, names):
            if caught in (Exception, BaseException):
                found.append(f"{where} except {caught.__name__} raises anew")
            elif caught is None:
                found.append(f"{where} except {ast.unparse(handler.type or ast.Pass())}: unknown")
            elif (
                inspect.isclass(caught)
                and issubclass(caught, fw1394.Error)
                and any(_raised_name(r).endswith("CliError") for r in raised)
            ):
                found.append(f"{where} re-wraps {caught.__name__} into CliError")
    return found


def test_no_command_rewraps_a_library_error_or_catches_everything() -> None:
    offenders = [line for path in sorted(CLI.glob("*.py")) for line in rewraps(path)]
    assert offenders == []


def test_the_check_finds_a_rewrap_a_catch_all_and_an_unknown(tmp_path: Path) -> None:
    planted = tmp_path / "planted.py"
    planted.write_text(
        "from fw1394.capture.formats import sources\n"
        "from fw1394.cli.common import CliError\n"
        "def run():\n"
        "    try:\n"
        "        from fw1394.capture.views.display_filter import FilterError\n"
        "    except FilterError as error:\n"
        "        raise CliError(str(error)) from None\n"
        "    try:\n"
        "        pass\n"
        "    except sources.SourceError as error:\n"
        "        raise CliError(f'x: {error}') from None\n"
        "    try:\n"
        "        pass\n"
        "    except Exception as error:\n"
        "        raise RuntimeError(error) from error\n"
        "    try:\n"
        "        pass\n"
        "    except port_errors() as error:\n"
        "        raise CliError(str(error)) from None\n"
        "    try:\n"
        "        pass\n"
        "    except (OSError, ValueError) as error:  # not the library's: context is fine\n"
        "        raise CliError(f'cannot: {error}') from None\n"
        "    except BaseException:\n"
        "        raise\n"
    )
    assert rewraps(planted) == [
        "planted.py:6 re-wraps FilterError into CliError",
        "planted.py:10 re-wraps SourceError into CliError",
        "planted.py:14 except Exception raises anew",
        "planted.py:18 except port_errors(): unknown",
    ]


@pytest.mark.parametrize(
    ("error", "line"),
    [
        (FileNotFoundError(errno.ENOENT, "No such file or directory", "t.pcapng"),
         "fw1394: error: t.pcapng: No such file or directory"),
        (ConnectionRefusedError(errno.ECONNREFUSED, "Connection refused"),
         "fw1394: error: Connection refused"),
        (OSError("socket\nclosed"), "fw1394: error: socket closed"),
    ],
)  # fmt: skip
def test_an_os_error_reaching_main_is_one_line_and_status_2(
    error: OSError, line: str, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    parser = cli_main.build_parser()
    args = parser.parse_args(["decode", "00"])

    def failing(_args: object) -> int:
        raise error

    args.handler = failing
    monkeypatch.setattr(parser, "parse_args", lambda _argv: args)
    monkeypatch.setattr(cli_main, "build_parser", lambda _command=None: parser)
    assert cli_main.main(["decode", "00"]) == 2
    captured = capsys.readouterr()
    assert (captured.out, captured.err) == ("", line + "\n")
