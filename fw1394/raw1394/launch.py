"""Running a program with the library in place, pointed at one bus."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from fw1394.raw1394.build import library_directory
from fw1394.transport.supervision.runtime import adapter_socket, bus_dir

#: The variables the library reads: the adapter's socket, and the bus's name.
ADAPTER_VARIABLE = "FW1394_ADAPTER"
BUS_VARIABLE = "FW1394_BUS"


def environment(
    name: str, root: Path | None = None, base: Mapping[str, str] | None = None
) -> dict[str, str]:
    """``base`` (the current environment) with the library first on the search path
    and bus ``name`` as the program's first port."""
    env = dict(os.environ if base is None else base)
    directory = str(library_directory())
    search = env.get("LD_LIBRARY_PATH")
    env["LD_LIBRARY_PATH"] = directory if not search else f"{directory}:{search}"
    env[ADAPTER_VARIABLE] = str(adapter_socket(bus_dir(name, root)))
    env[BUS_VARIABLE] = name
    return env
