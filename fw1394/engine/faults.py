"""The one fault model: what goes wrong with the packets a member sends.

Loss, duplication and delay are what a transaction layer must survive on any
medium. A member of the virtual bus injects them into its outgoing
asynchronous packets and acks (bus-management frames are left alone, so a
faulty node still takes part in bus resets, as a real PHY does when its link
misbehaves); the in-memory loopback (:mod:`fw1394.engine.loopback`) injects
them into every packet it carries, through the same :class:`FaultInjector`.
The loopback also corrupts packets (one bit flips; the CRCs will tell),
reorders them and loses acks: those need the wire bytes and the ack path that
only it sees, so a bus member ignores them.

Sans-IO like the rest of the engine: the injector decides send times from
``now`` and its own random stream.
"""

from __future__ import annotations

import random
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class FaultConfig:
    """Probabilities (0..1) per packet sent; ``delay_seconds``: how late a delayed one is."""

    #: The packet is lost.
    loss: float = 0.0
    #: The packet arrives twice.
    duplicate: float = 0.0
    #: The packet arrives ``delay_seconds`` late.
    delay: float = 0.0
    delay_seconds: float = 0.002
    #: Loopback only: one bit of the packet flips.
    corrupt: float = 0.0
    #: Loopback only: the packet is held until everything already in flight has arrived.
    reorder: float = 0.0
    #: Loopback only: the requester never hears the ack a node sent.
    lose_ack: float = 0.0
    #: The random stream's seed (None: a fresh one); the loopback uses its own seed.
    seed: int | None = None

    def __post_init__(self) -> None:
        for name in ("loss", "duplicate", "delay", "corrupt", "reorder", "lose_ack"):
            value = getattr(self, name)
            if not 0.0 <= value <= 1.0:
                raise ValueError(f"--{name} {value} is not a probability between 0 and 1")
        if self.delay_seconds < 0:
            raise ValueError(f"delay of {self.delay_seconds} s is negative")

    @property
    def active(self) -> bool:
        """Whether a bus member has anything to inject."""
        return bool(self.loss or self.duplicate or self.delay)


class FaultInjector:
    """Decides what happens to each packet sent; counts what it did."""

    def __init__(self, config: FaultConfig, stream: random.Random | None = None) -> None:
        self.config = config
        self._random = random.Random(config.seed) if stream is None else stream
        self.lost = self.duplicated = self.delayed = 0

    def send_times(self, now: float) -> list[float]:
        """When the packet sent at ``now`` arrives: never (lost), once, or twice (duplicated)."""
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


__all__ = ["FaultConfig", "FaultInjector"]
