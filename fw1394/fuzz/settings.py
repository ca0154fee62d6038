"""Everything a campaign is run with, in one value that findings keep for replays."""

from __future__ import annotations

from dataclasses import asdict, dataclass, fields
from typing import Any

from fw1394.boards.registry import BOARDS
from fw1394.errors import UsageError
from fw1394.fuzz.contract import CONTRACTS
from fw1394.packets.nodeid import node_id

#: The contract a node is held to when its kind's own policy is no contract
#: (``quick`` skips checks a contract is about).
FALLBACK_POLICY = "thesis"
LOCAL_NODE_0 = node_id(0)
#: Speeds an rtl: campaign delivers packets at.
RTL_SPEEDS = ("S100", "S200", "S400", "mixed")
RTL_DEFAULTS = {"speed": "S400", "sclk_mhz": 49.152}


def default_policy(kind: str | None) -> str:
    """The contract a board of ``kind`` answers by when fuzzed in-process and none is named.

    Its registry policy (the QLA answers like the JHU firmware), when that is a contract.
    """
    entry = BOARDS.get(kind or "")
    policy = entry.policy if entry else FALLBACK_POLICY
    return policy if policy in CONTRACTS else FALLBACK_POLICY


class SettingsError(UsageError):
    """Settings that cannot work together (one line for the user)."""


@dataclass(frozen=True)
class Settings:
    """A campaign's target, contract, model and limits."""

    #: ``inproc:BOARD``, ``bus:NAME/NODE``, ``udp:HOST[:PORT]`` or ``rtl:PORTMAP``.
    target: str
    #: The contract the node is held to: a key of :data:`CONTRACTS`.
    contract: str = "thesis"
    #: Board kind of the reference model; None: the target's kind (in-process) or
    #: no model (remote: replies are checked for presence and routing only).
    model: str | None = None
    board_id: int = 0
    #: The node's 16-bit ID (in-process and UDP; a bus node's comes from the bus).
    node_id: int = LOCAL_NODE_0
    #: In-process only: how the fuzzed node answers (default: its board's own way).
    policy: str | None = None
    #: Planted defects (in-process: the target's; remote: recorded only).
    defects: tuple[str, ...] = ()
    seed: int = 0
    max_cases: int | None = None
    duration: float | None = None
    #: In-process, a liveness probe after every N cases (a read-back after each write
    #: is a liveness check too); remote targets probe after every case.
    probe_every: int = 4
    #: Sweep of the board's registers every N cases (0: never).
    state_every: int = 64
    #: Seconds a remote target has to answer a batch.
    timeout: float = 0.5
    #: Seconds a remote target may stay silent before the campaign gives up.
    dead_after: float = 3.0
    #: udp: speak the JHU Eth1394 framing instead of fw1394's tunnel.
    eth1394: bool = False
    #: Seed corpus files (hex lines or captures).
    corpus: tuple[str, ...] = ()
    #: Replays the shrinker may spend per finding.
    shrink_budget: int = 300
    #: Packets of history kept for each finding.
    history: int = 512
    #: Offset of the liveness probe read (None: the model's usual one).
    probe_offset: int | None = None
    #: udp: the pid of the node's process, to watch it stays alive.
    pid: int | None = None
    #: rtl: the speed packets are delivered at (S100, S200, S400, or mixed: each its own).
    speed: str = "S400"
    #: rtl: the SCLK frequency the design runs at, MHz.
    sclk_mhz: float = 49.152

    def __post_init__(self) -> None:
        self._check_types()
        if self.contract not in CONTRACTS:
            raise SettingsError(
                f"unknown contract {self.contract!r}; known: {', '.join(CONTRACTS)}"
            )
        if self.policy is not None and self.policy not in CONTRACTS:
            raise SettingsError(f"unknown policy {self.policy!r}; known: {', '.join(CONTRACTS)}")
        for name in ("probe_every", "history"):
            if getattr(self, name) < 1:
                raise SettingsError(f"{name.replace('_', '-')} must be at least 1")
        for name in ("state_every", "shrink_budget"):
            if getattr(self, name) < 0:
                raise SettingsError(f"{name.replace('_', '-')} must not be negative")
        if self.max_cases is not None and self.max_cases < 0:
            raise SettingsError("max-cases must not be negative")
        for name in ("duration", "timeout", "dead_after"):
            value = getattr(self, name)
            if value is not None and not value > 0:
                raise SettingsError(f"{name.replace('_', '-')} must be positive")
        if not 0 <= self.node_id <= 0xFFFF:
            raise SettingsError(f"node ID {self.node_id:#x} does not fit 16 bits")
        if self.speed not in RTL_SPEEDS:
            raise SettingsError(f"speed {self.speed!r}: use {', '.join(RTL_SPEEDS)}")
        if not 1 <= self.sclk_mhz <= 1000:
            raise SettingsError("sclk-mhz must be between 1 and 1000")
        if self.probe_offset is not None and not 0 <= self.probe_offset < 1 << 48:
            raise SettingsError(f"probe offset {self.probe_offset:#x} does not fit 48 bits")

    def _check_types(self) -> None:
        # Settings also come back from finding files, which anyone can edit.
        for field in fields(self):
            value = getattr(self, field.name)
            wanted = _TYPES[field.name]
            optional = field.name in _OPTIONAL
            if value is None and optional:
                continue
            allowed = (int, float) if wanted is float else (wanted,)
            if (isinstance(value, bool) and wanted is not bool) or not isinstance(value, allowed):
                raise SettingsError(f"{field.name}: {value!r} is not a {wanted.__name__}")

    @property
    def scheme(self) -> str:
        return self.target.split(":", 1)[0]

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["defects"] = list(self.defects)
        data["corpus"] = list(self.corpus)
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Settings:
        """Settings as :meth:`to_json` wrote them; :class:`SettingsError` for anything else."""
        known = {f.name for f in fields(cls)}
        try:
            values = {k: v for k, v in data.items() if k in known}
            for name in ("defects", "corpus"):
                values[name] = tuple(str(item) for item in values.get(name, ()))
            return cls(**values)
        except SettingsError:
            raise
        except (AttributeError, TypeError, ValueError) as error:
            raise SettingsError(f"settings of a finding: {error}") from None


_TYPES: dict[str, type] = {
    **{name: str for name in ("target", "contract", "model", "policy", "speed")},
    **{name: tuple for name in ("defects", "corpus")},
    **{name: float for name in ("duration", "timeout", "dead_after", "sclk_mhz")},
    "eth1394": bool,
    **{
        name: int
        for name in (
            "board_id",
            "node_id",
            "seed",
            "max_cases",
            "probe_every",
            "state_every",
            "shrink_budget",
            "history",
            "probe_offset",
            "pid",
        )
    },
}
_OPTIONAL = frozenset({"model", "policy", "max_cases", "duration", "probe_offset", "pid"})
