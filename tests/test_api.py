"""The public API: what ``__all__`` promises exists and is documented, and docs use only it.

The public API is ``fw1394`` and every package's ``__init__``: the names in
their ``__all__``. The checks here hold every package to that: it declares
``__all__``, each name resolves (many load on first use), each function and
class carries its own docstring, and the Python examples in the README and in
``docs/`` import nothing else.
"""

from __future__ import annotations

import ast
import doctest
import importlib
import inspect
import pkgutil
import re
import subprocess
import sys
from pathlib import Path
from types import ModuleType

import pytest

import fw1394

ROOT = Path(__file__).resolve().parent.parent


def _packages() -> list[ModuleType]:
    found = [fw1394]
    for info in pkgutil.walk_packages(fw1394.__path__, "fw1394."):
        if info.ispkg:
            found.append(importlib.import_module(info.name))
    return found


PACKAGES = _packages()


def test_the_walk_finds_every_package() -> None:
    names = {p.__name__ for p in PACKAGES}
    assert {"fw1394", "fw1394.packets", "fw1394.capture.formats", "fw1394.boards.qla1"} <= names


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: p.__name__)
def test_every_package_declares_its_public_names(package: ModuleType) -> None:
    names = getattr(package, "__all__", None)
    assert isinstance(names, list)
    assert len(names) == len(set(names))
    assert package.__doc__ and package.__doc__.strip()


@pytest.mark.parametrize("package", PACKAGES, ids=lambda p: p.__name__)
def test_every_public_name_resolves_and_is_documented(package: ModuleType) -> None:
    undocumented = []
    for name in package.__all__:
        value = getattr(package, name)
        if inspect.ismodule(value):
            continue
        callable_ = inspect.isclass(value) or inspect.isfunction(value)
        if callable_ and not _own_docstring(value):
            undocumented.append(name)
    assert undocumented == []


def _own_docstring(value: object) -> str:
    """The docstring written for ``value``: not inherited, not made up by a decorator."""
    doc = (value.__dict__.get("__doc__") if inspect.isclass(value) else value.__doc__) or ""
    name = getattr(value, "__name__", "")
    # dataclass writes the signature when a class has no docstring of its own.
    if doc.startswith(f"{name}(") or doc == "An enumeration.":
        return ""
    return doc.strip()


def test_dir_lists_the_names_that_load_on_first_use() -> None:
    assert {"open_bus", "decode", "Error", "PcapngReader"} <= set(dir(fw1394))
    with pytest.raises(AttributeError, match="no_such_name"):
        _ = fw1394.no_such_name


def test_the_package_docstring_examples_run() -> None:
    results = doctest.testmod(fw1394, verbose=False)
    assert results.attempted > 0
    assert results.failed == 0


@pytest.mark.process
def test_importing_fw1394_loads_none_of_the_heavy_layers() -> None:
    # A fresh interpreter: this one has imported everything already.
    code = (
        "import sys, fw1394\n"
        "heavy = [m for m in sys.modules if m.startswith(('fw1394.transport', "
        "'fw1394.capture', 'fw1394.fuzz', 'fw1394.boards', 'fw1394.engine', 'numpy'))]\n"
        "print(heavy)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"


# -- examples in the docs ----------------------------------------------------------------

_FENCE = re.compile(r"^```(?:python|py|pycon)\n(.*?)^```", re.S | re.M)


def _doc_files() -> list[Path]:
    return [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]


def _examples() -> list[tuple[str, str]]:
    found = []
    for path in _doc_files():
        for block in _FENCE.findall(path.read_text()):
            code = "\n".join(
                line.removeprefix(">>> ").removeprefix("... ")
                for line in block.splitlines()
                if not line.startswith(("$ ",))
            )
            found.append((str(path.relative_to(ROOT)), code))
    return found


def _non_public_imports(code: str) -> list[str]:
    """Imports of fw1394 in ``code`` that reach past a package's ``__all__``."""
    wrong = []
    for node in ast.walk(ast.parse(code)):
        if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("fw1394"):
            module = importlib.import_module(node.module or "")
            public = getattr(module, "__all__", None) if hasattr(module, "__path__") else None
            for alias in node.names:
                if public is None or alias.name not in public:
                    wrong.append(f"from {node.module} import {alias.name}")
        elif isinstance(node, ast.Import):
            for alias in node.names:
                if alias.name.startswith("fw1394"):
                    module = importlib.import_module(alias.name)
                    if not hasattr(module, "__path__"):
                        wrong.append(f"import {alias.name}")
    return wrong


def test_docs_have_python_examples_to_check() -> None:
    assert sum("fw1394" in code for _, code in _examples()) >= 5


def test_doc_examples_import_only_the_public_api() -> None:
    wrong = [
        f"{where}: {text}"
        for where, code in _examples()
        if "fw1394" in code
        for text in _non_public_imports(code)
    ]
    assert wrong == []


@pytest.mark.parametrize(
    "code",
    [
        "from fw1394.host.bus_port import BusPort",
        "import fw1394.packets.fast",
        "from fw1394.packets import decode_header",
    ],
)
def test_the_doc_check_catches_a_private_import(code: str) -> None:
    assert _non_public_imports(code) != []


def test_the_doc_check_accepts_public_imports() -> None:
    code = "import fw1394\nfrom fw1394 import open_bus\nfrom fw1394.fuzz import strategies\n"
    assert _non_public_imports(code) == []
