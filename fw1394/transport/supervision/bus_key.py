"""The bus key: made by ``bus up``, kept in the bus's runtime directory, found by members.

The key is 32 random bytes written in hex to ``key`` (mode 0600) in the bus's
runtime directory; a member on another host gets it from ``$FW1394_BUS_KEY``
or a file named by ``$FW1394_BUS_KEY_FILE``. What the key does to frames is
:mod:`fw1394.transport.sansio.seal`'s business; this module only keeps it.
"""

from __future__ import annotations

import os
from pathlib import Path

from fw1394.errors import UsageError
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.runtime import KEY_FILE, bus_dir

KEY_SIZE = 32
#: The key of the bus a process joins, in hex (members on other hosts).
KEY_ENV = "FW1394_BUS_KEY"
#: A file holding that key (what ``bus up`` passes to the nodes it starts).
KEY_FILE_ENV = "FW1394_BUS_KEY_FILE"


class BusKeyError(UsageError):
    """A key file or variable that does not hold a usable bus key."""


def new_key() -> bytes:
    return os.urandom(KEY_SIZE)


def write_key(path: Path, key: bytes) -> None:
    """Write ``key`` (hex) to a new file only its owner can read.

    The directories above must be this user's and not writable by others (the
    runtime root under /tmp has a name anyone can guess and create first); the
    file is made anew, never through a link someone left there.
    """
    for directory in (path.parent, path.parent.parent):
        info = directory.lstat()
        if info.st_uid != os.getuid() or info.st_mode & 0o022:
            raise BusKeyError(f"{directory}: not a private directory of this user")
    path.unlink(missing_ok=True)
    flags = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW
    with os.fdopen(os.open(path, flags, 0o600), "w") as out:
        out.write(key.hex() + "\n")


def parse_key(text: str, where: str) -> bytes:
    try:
        key = bytes.fromhex(text.strip())
    except ValueError:
        raise BusKeyError(f"{where}: not a hex bus key") from None
    if not 16 <= len(key) <= KEY_SIZE:
        raise BusKeyError(f"{where}: a bus key has 16 to {KEY_SIZE} bytes, not {len(key)}")
    return key


def read_key(path: Path) -> bytes:
    """The key in ``path``; refused if others than its owner may read it."""
    info = path.stat()
    if info.st_mode & 0o077 or info.st_uid != os.getuid():
        raise BusKeyError(f"{path}: a bus key must be this user's, readable by them only (600)")
    return parse_key(path.read_text(), str(path))


def key_for(config: BusConfig) -> bytes | None:
    """The key of ``config``'s bus: its own, else :func:`find_key`; None: insecure.

    ``BusConfig(key=b"")`` is a member that stays insecure whatever it finds.
    """
    if config.key is not None:
        return config.key or None
    return find_key(bus_dir(config.name) / KEY_FILE)


def find_key(key_file: Path | None) -> bytes | None:
    """The bus key this process uses: ``$FW1394_BUS_KEY``, ``$FW1394_BUS_KEY_FILE``,
    else ``key_file`` (the bus's runtime directory) if it exists; None: insecure."""
    if text := os.environ.get(KEY_ENV):
        return parse_key(text, KEY_ENV)
    if named := os.environ.get(KEY_FILE_ENV):
        return read_key(Path(named))
    if key_file is not None and key_file.exists():
        return read_key(key_file)
    return None
