"""Replaying saved findings: does each violation still happen?

With a restart hook a remote node is brought up afresh before every stream,
so findings that need a state built up from power-up reproduce too.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

from fw1394.fuzz.campaign import open_campaign_target, replayer
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.restart import RestartHook, hook_of
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.target import Target


@dataclass(frozen=True)
class ReplayResult:
    """One saved finding replayed: whether it reproduced, and what else showed."""

    path: Path
    finding: Finding
    target: str
    reproduced: bool
    #: Other violations the replay showed (oracle:signature).
    others: tuple[str, ...]

    def line(self) -> str:
        verdict = "REPRODUCED" if self.reproduced else "not reproduced"
        text = f"{verdict:<14} {self.finding.oracle}:{self.finding.signature} on {self.target}"
        text += f" ({self.path.name})"
        if self.others:
            text += f"; also {', '.join(self.others)}"
        return text

    def to_json(self) -> dict[str, Any]:
        return {
            "file": str(self.path),
            "oracle": self.finding.oracle,
            "signature": self.finding.signature,
            "target": self.target,
            "reproduced": self.reproduced,
            "others": list(self.others),
        }


def replay_all(
    loaded: list[tuple[Path, Finding]],
    target: str | None,
    restart: str | RestartHook | None = None,
) -> list[ReplayResult]:
    """Replay every finding, on ``target`` if given, else on the one it was found on.

    ``restart`` (a shell command or a callable) brings a remote node up afresh
    before each stream. Targets are opened once per distinct setting, so a
    remote node is joined once.
    """
    opened: dict[Settings, Target] = {}
    results = []
    try:
        for path, finding in loaded:
            settings = Settings.from_json(finding.settings)
            if target is not None:
                # Defects are planted in-process (or in the simulated RTL) only; a
                # remote node brings its own.
                keep = settings.defects if target.startswith(("inproc:", "rtl:")) else ()
                settings = replace(settings, target=target, defects=keep)
            if settings not in opened:
                remote = settings.scheme != "inproc"
                opened[settings] = open_campaign_target(
                    settings, hook_of(restart) if remote else None
                )
            seen = replayer(settings, opened[settings])(finding.stream)
            others = tuple(sorted(f"{o}:{s}" for o, s in seen - {finding.key}))
            results.append(
                ReplayResult(path, finding, settings.target, finding.key in seen, others)
            )
    finally:
        for opened_target in opened.values():
            opened_target.close()
    return results
