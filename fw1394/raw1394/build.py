"""Compiling ``shim.c`` into ``libraw1394.so.11``, once per source and compiler.

The library lands in a per-user cache directory (``$XDG_CACHE_HOME/fw1394``,
or ``~/.cache/fw1394``), under a name derived from the source's hash, so a new
version of fw1394 builds its own copy and an old one is never loaded by
mistake. The build compiles against the system's libraw1394 headers (Debian's
``libraw1394-dev``) so that the structures and constants match the ABI the
programs were built for.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from importlib import resources
from pathlib import Path

from fw1394.errors import Error

#: The name programs linked against libraw1394 load.
SONAME = "libraw1394.so.11"
#: Where the libraw1394 headers live on Debian and most distributions.
HEADER = Path("/usr/include/libraw1394/raw1394.h")
_FLAGS = ("-O2", "-fPIC", "-shared", "-Wall", f"-Wl,-soname,{SONAME}")


class BuildError(Error, RuntimeError):
    """The library cannot be built here; the message says what to install."""


def source() -> bytes:
    return resources.files("fw1394.raw1394").joinpath("shim.c").read_bytes()


def cache_root() -> Path:
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "fw1394" / "libraw1394"


def compiler() -> str:
    """The C compiler to use: ``$CC``, else ``cc`` or ``gcc`` on ``PATH``."""
    for name in (os.environ.get("CC"), "cc", "gcc"):
        if name and shutil.which(name.split()[0]):
            return name
    raise BuildError(
        "no C compiler to build libraw1394.so.11 with: install gcc (Debian: apt install gcc)"
    )


def library_directory() -> Path:
    """The directory holding a built ``libraw1394.so.11`` (built now if need be)."""
    code = source()
    cc = compiler()
    digest = hashlib.sha256(code + cc.encode()).hexdigest()[:16]
    directory = cache_root() / digest
    if (directory / SONAME).exists():
        return directory
    if not HEADER.exists():
        raise BuildError(
            f"libraw1394's headers are missing ({HEADER}): install them "
            "(Debian: apt install libraw1394-dev)"
        )
    directory.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(dir=directory) as work:
        shim = Path(work) / "shim.c"
        shim.write_bytes(code)
        built = Path(work) / SONAME
        command = [*cc.split(), *_FLAGS, "-o", str(built), str(shim)]
        result = subprocess.run(command, capture_output=True, text=True, check=False)
        if result.returncode != 0:
            first = (result.stderr.strip().splitlines() or ["no message"])[0]
            raise BuildError(f"building libraw1394.so.11 with {cc} failed: {first}")
        # A rename is atomic: a program started meanwhile sees no half-written file.
        built.replace(directory / SONAME)
    return directory


def library_path() -> Path:
    """Where ``libraw1394.so.11`` is (built now if need be)."""
    return library_directory() / SONAME
