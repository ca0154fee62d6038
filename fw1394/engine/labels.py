"""Transaction labels: 64 per destination, never two live with the same one.

A label is *live* from the start of its transaction until a stale answer to
that transaction can no longer arrive: the transaction's end, plus a hold time
the requester chooses. A late or duplicated response carries nothing but the
source, the label and the tcode to tell which transaction it answers, so a
label handed out again while such a response is on its way would let that
response complete the wrong transaction.
"""

from __future__ import annotations

import heapq

LABELS = 64
_ALL_HELD = (1 << LABELS) - 1


class LabelPool:
    """Hands out labels per key (the destination's physical ID), round robin.

    Round robin rather than lowest-free: a label comes back only after the 63
    others to the same node have been used, so that a stale response most often
    finds its label unused (and is recognised as unexpected) even before the
    hold, which makes sure of it, is over.
    """

    __slots__ = ("_held", "_next", "_until")

    def __init__(self) -> None:
        #: key -> bit mask of labels not free (in use or held after their end).
        self._held: dict[int, int] = {}
        #: key -> the label to try first next time.
        self._next: dict[int, int] = {}
        #: key -> heap of (free from, label) of the labels held after their end.
        self._until: dict[int, list[tuple[float, int]]] = {}

    def take(self, key: int, now: float) -> int | None:
        """A free label to ``key``, or ``None`` while all 64 are in use or held."""
        mask = self._held.get(key, 0)
        if mask == _ALL_HELD:
            mask = self._expire(key, now)
            if mask == _ALL_HELD:
                return None
        label = self._next.get(key, 0)
        while mask >> label & 1:
            label = (label + 1) % LABELS
        self._held[key] = mask | 1 << label
        self._next[key] = (label + 1) % LABELS
        return label

    def release(self, key: int, label: int, until: float | None = None) -> None:
        """The transaction on ``label`` has ended: free it now, or from ``until`` on."""
        if until is None:
            self._held[key] &= ~(1 << label)
        else:
            heapq.heappush(self._until.setdefault(key, []), (until, label))

    def free_from(self, key: int) -> float | None:
        """When the next held label to ``key`` becomes free; ``None``: none is held."""
        holds = self._until.get(key)
        return holds[0][0] if holds else None

    def in_use(self, key: int) -> int:
        """How many labels to ``key`` are not free (in use, or held after their end)."""
        return self._held.get(key, 0).bit_count()

    def release_all(self) -> None:
        """Every label is free again (a bus reset voids every answer); the rotation goes on."""
        self._held.clear()
        self._until.clear()

    def _expire(self, key: int, now: float) -> int:
        # Only run when every label is taken: a held label left marked a while
        # longer is still correct, and the rotation reaches it last anyway.
        mask = self._held[key]
        holds = self._until.get(key)
        while holds and holds[0][0] <= now:
            mask &= ~(1 << heapq.heappop(holds)[1])
        self._held[key] = mask
        return mask
