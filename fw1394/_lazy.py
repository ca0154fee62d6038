"""Public names of a package imported on first use (PEP 562).

A package whose ``__init__`` would otherwise import its heaviest modules (the
fuzzer, the whole library at the top) names where each public name lives and
lets this load it when someone asks, so importing one submodule stays cheap.
"""

from __future__ import annotations

import importlib
import importlib.util
from collections.abc import Callable, Mapping
from typing import Any


def exports(
    package: str, namespace: dict[str, Any], homes: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of ``package``, whose names live in ``homes``.

    ``homes`` maps a public name to the module that defines it (``module:name``
    when it is defined there under another name); the first use imports it and
    stores it in ``namespace`` (the package's globals), so later uses are plain
    attribute reads. Submodules load on first use too.
    """

    def getattr_(name: str) -> object:
        home = homes.get(name)
        if home is None:
            # A subpackage or module: ``import fw1394`` then ``fw1394.fuzz.run``.
            if not name.startswith("_") and importlib.util.find_spec(f"{package}.{name}"):
                return importlib.import_module(f"{package}.{name}")
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        module, _, defined_as = home.partition(":")
        value = getattr(importlib.import_module(module), defined_as or name)
        namespace[name] = value
        return value

    def dir_() -> list[str]:
        return sorted(set(namespace) | set(homes))

    return getattr_, dir_
