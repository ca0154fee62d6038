"""A problem found in the input, with where it is (no numpy: live capture uses it too)."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Issue:
    """Something wrong in the input, at byte ``position`` (or line, for text)."""

    position: int
    message: str
    unit: str = "byte"
    #: The input ends inside this record: the file was cut short (tshark exits 2 for it).
    cut_short: bool = False

    def __str__(self) -> str:
        return f"{self.unit} {self.position}: {self.message}"
