"""Column tables: a dict of equally long numpy arrays."""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

Table = dict[str, np.ndarray]


def rows(table: Mapping[str, np.ndarray]) -> int:
    return len(next(iter(table.values()))) if table else 0


def empty(names: Sequence[str]) -> Table:
    return {name: np.zeros(0, np.int64) for name in names}
