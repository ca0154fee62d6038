"""Fault injection on a member's outgoing asynchronous traffic.

Loss, duplication and delay hit async packets and acks (the subactions a
transaction layer must survive); bus-management frames are left alone so that
a faulty node still takes part in bus resets, as a real PHY does even when
its link misbehaves.
"""

from __future__ import annotations

import random
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class FaultConfig:
    """Probabilities (0..1) per outgoing frame; ``delay_seconds`` for delayed ones."""

    loss: float = 0.0
    duplicate: float = 0.0
    delay: float = 0.0
    delay_seconds: float = 0.002
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("loss", "duplicate", "delay"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"--{name} {value} is not a probability between 0 and 1")
        if self.delay_seconds < 0:
            raise ValueError(f"delay of {self.delay_seconds} s is negative")

    @property
    def active(self) -> bool:
        return bool(self.loss or self.duplicate or self.delay)


class FaultInjector:
    """Decides what happens to each outgoing frame."""

    def __init__(self, config: FaultConfig) -> None:
        self.config = config
        self._random = random.Random(config.seed)
        self.lost = self.duplicated = self.delayed = 0

    def send_times(self, now: float) -> list[float]:
        """When to put the frame on the bus: none (lost), once, or twice (duplicated)."""
        cfg = self.config
        chance = self._random.random
        if cfg.loss and chance() < cfg.loss:
            self.lost += 1
            return []
        when = now
        if cfg.delay and chance() < cfg.delay:
            self.delayed += 1
            when = now + cfg.delay_seconds
        if cfg.duplicate and chance() < cfg.duplicate:
            self.duplicated += 1
            return [when, when]
        return [when]
