"""The one place fw1394 turns generated source into functions.

The hot paths (packet codecs, field readers, the engine's common turns) are
straight-line functions written from the packet layouts at import time. Each
is compiled here under a file name of its own and its source is registered in
:mod:`linecache`, so a traceback, ``pdb`` and ``inspect.getsource`` show the
generated line that ran instead of ``File "<string>", line 1``. Nothing else
in the package calls ``exec`` or ``eval`` (a test holds that).

A text is compiled once: every responder generates its common turns, and the
same policy gives the same text, so later ones take a copy of the compiled code
under a file name of their own.
"""

from __future__ import annotations

import itertools
import linecache
from collections.abc import Callable, Iterable
from types import CodeType
from typing import Any

#: Numbers the generated files: two functions made from the same text stay apart.
_serial = itertools.count(1)
#: Each text's code, compiled once.
_compiled: dict[str, CodeType] = {}


def generated_filename(origin: str) -> str:
    """A file name no other generated function has, naming where the source came from."""
    return f"<fw1394-generated {origin} #{next(_serial)}>"


def compile_function(
    source: str | Iterable[str], namespace: dict[str, Any], name: str, *, origin: str
) -> Callable[..., Any]:
    """Function ``name`` defined by ``source`` (text, or lines without their newlines).

    ``namespace`` holds the globals the source uses; ``origin`` says what made it
    (``"fw1394.packets.fast encode QuadletReadRequest"``) and goes into the file name
    that tracebacks print.
    """
    text = source if isinstance(source, str) else "\n".join(source) + "\n"
    filename = generated_filename(origin)
    code = _compiled.get(text)
    if code is None:
        code = _compiled[text] = compile(text, filename, "exec")
    else:
        code = _renamed(code, filename)
    # mtime None: linecache.checkcache keeps the entry (there is no file to recheck).
    linecache.cache[filename] = (len(text), None, text.splitlines(keepends=True), filename)
    exec(code, namespace)
    function: Callable[..., Any] = namespace[name]
    return function


def _renamed(code: CodeType, filename: str) -> CodeType:
    """``code`` and the functions it defines, as if compiled under ``filename``."""
    constants = tuple(
        _renamed(item, filename) if isinstance(item, CodeType) else item
        for item in code.co_consts
    )
    return code.replace(co_filename=filename, co_consts=constants)


__all__ = ["compile_function", "generated_filename"]
