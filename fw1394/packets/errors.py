"""The one error type the codec raises."""

from __future__ import annotations


class PacketError(ValueError):
    """A packet could not be decoded or encoded.

    ``field`` names the field at fault (``"header_crc"``, ``"tcode"``,
    ``"length"``, ...) and ``problem`` says what is wrong with it; ``str()``
    gives both in one line.
    """

    def __init__(self, field: str, problem: str) -> None:
        super().__init__(f"{field}: {problem}")
        self.field = field
        self.problem = problem
