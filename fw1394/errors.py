"""The exceptions of fw1394: one base, :class:`Error`, and a few kinds under it.

Every exception class fw1394 defines derives from :class:`Error`, so a program
that uses the library catches ``fw1394.Error`` once and knows it has caught
everything the library raises on purpose (anything else is a bug). The kinds
say what went wrong, not where:

- :class:`UsageError`: the caller's input is not acceptable (a value, a name,
  an option, a file's contents as a setting);
- :class:`PacketError`: bytes do not form a valid packet, frame or record;
- :class:`TransactionError`: a 1394 transaction ended without success; it
  carries the ack and the response code when the bus gave them;
- :class:`BusUnreachable`: the bus, a node or a target cannot be reached;
- :class:`Timeout`: nothing answered in time.

The input and format kinds also derive from ``ValueError``, which they were
before, so existing ``except ValueError`` clauses keep working. The others do
not derive from ``OSError`` (``ConnectionError``, ``TimeoutError``): its
constructor reads two arguments as an errno and a message.

This module imports nothing of fw1394: every layer may raise these.
"""

from __future__ import annotations

__all__ = [
    "BusUnreachable",
    "Error",
    "PacketError",
    "Timeout",
    "TransactionError",
    "UsageError",
]


class Error(Exception):
    """Base class of every exception fw1394 raises on purpose.

    ``str(error)`` is one line meant for a person; the command-line tool
    prints it as ``fw1394: error: ...`` and exits with status 2.
    """


class UsageError(Error, ValueError):
    """The caller's input is not acceptable: a value, name, option or setting."""


class PacketError(Error, ValueError):
    """Bytes do not form a valid packet, frame or record, or a value does not encode.

    Raised as ``PacketError(field, problem)``: ``field`` names the field at
    fault (``"header_crc"``, ``"tcode"``, ``"length"``, ...) and ``problem``
    says what is wrong with it; ``str()`` gives both in one line. A problem
    with the whole record rather than one field is raised as
    ``PacketError(problem)`` and has an empty ``field``.
    """

    field: str
    problem: str

    def __init__(self, field: str, problem: str | None = None) -> None:
        if problem is None:
            field, problem = "", field
        super().__init__(f"{field}: {problem}" if field else problem)
        self.field = field
        self.problem = problem


class TransactionError(Error):
    """A 1394 transaction ended without success.

    ``ack`` is the acknowledge code (``fw1394.packets.AckCode``) that ended it,
    or ``None`` when no ack was at fault; ``rcode`` is the response code
    (``fw1394.packets.RCode``) of an error response, or ``None``.
    """

    ack: int | None = None
    rcode: int | None = None

    def __init__(self, message: str = "", *, ack: int | None = None, rcode: int | None = None):
        super().__init__(message)
        if ack is not None:
            self.ack = ack
        if rcode is not None:
            self.rcode = rcode


class BusUnreachable(Error):
    """The bus, a node on it or a target cannot be reached, or refused to take us."""


class Timeout(Error):
    """Nothing answered within the time allowed."""
