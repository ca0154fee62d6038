"""Transaction labels: 64 per destination, never two outstanding with the same one."""

from __future__ import annotations

LABELS = 64
_ALL_IN_USE = (1 << LABELS) - 1


class LabelsExhausted(Exception):
    """All 64 labels to one destination belong to outstanding transactions."""

    def __init__(self, destination_id: int) -> None:
        super().__init__(
            f"all {LABELS} transaction labels to node {destination_id:#06x} are in use"
        )
        self.destination_id = destination_id


class LabelPool:
    """Hands out labels per key (the destination's physical ID), round robin.

    Round robin rather than lowest-free: a label comes back only after the 63
    others to the same node have been used, which gives a late or duplicated
    response the longest possible time to arrive while its label is still free
    (and so to be recognised as unexpected, not taken for a newer transaction's).
    """

    __slots__ = ("_in_use", "_next")

    def __init__(self) -> None:
        #: key -> bit mask of labels in use.
        self._in_use: dict[int, int] = {}
        #: key -> the label to try first next time.
        self._next: dict[int, int] = {}

    def take(self, key: int, destination_id: int) -> int:
        mask = self._in_use.get(key, 0)
        if mask == _ALL_IN_USE:
            raise LabelsExhausted(destination_id)
        label = self._next.get(key, 0)
        while mask >> label & 1:
            label = (label + 1) % LABELS
        self._in_use[key] = mask | 1 << label
        self._next[key] = (label + 1) % LABELS
        return label

    def give_back(self, key: int, label: int) -> None:
        self._in_use[key] &= ~(1 << label)

    def in_use(self, key: int) -> int:
        """How many labels to ``key`` are taken."""
        return self._in_use.get(key, 0).bit_count()

    def release_all(self) -> None:
        """Every label is free again (after a bus reset); the rotation continues."""
        self._in_use.clear()
