"""Waiting for a condition instead of sleeping for a guess."""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import TypeVar

T = TypeVar("T")


def wait_until(condition: Callable[[], T], timeout: float = 10.0, interval: float = 0.02) -> T:
    """The first true value ``condition()`` returns; AssertionError after ``timeout`` s.

    Checks at once, then every ``interval`` seconds, so a ready condition costs no
    wait and a slow machine only waits longer, never fails early.
    """
    limit = time.monotonic() + timeout
    while not (value := condition()):
        if time.monotonic() >= limit:
            raise AssertionError(f"not true within {timeout} s: {condition!r}")
        time.sleep(interval)
    return value
