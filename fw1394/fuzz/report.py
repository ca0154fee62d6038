"""The end-of-run report: cases, rate, distinct findings, coverage of kinds and oracles."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from fw1394.fuzz.coverage import never_hit, space
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.judge import ORACLES
from fw1394.fuzz.settings import Settings

#: Cases between two points of the timeline when nothing new happened.
TIMELINE_EVERY = 1024


@dataclass
class Report:
    """What a campaign did: cases run, time taken, why it stopped, the findings."""

    settings: Settings
    cases: int = 0
    elapsed: float = 0.0
    #: Why the run ended: max-cases, duration, target-gone, interrupted.
    stopped: str = ""
    findings: list[Finding] = field(default_factory=list)
    #: Packet kinds sent (tcode names, ``undecodable``).
    kinds: Counter[str] = field(default_factory=Counter)
    #: How the cases were made (valid, bad-header-crc, mutation+crc, ...).
    labels: Counter[str] = field(default_factory=Counter)
    #: Whom the cases were addressed to (ours, other-node, other-bus, broadcast, -).
    addressing: Counter[str] = field(default_factory=Counter)
    #: Checks made and violations seen (duplicates included), per oracle.
    checks: Counter[str] = field(default_factory=Counter)
    violations: Counter[str] = field(default_factory=Counter)
    #: Functional coverage: cases per bin (kind/outcome/speed/length/address,
    #: :mod:`fw1394.fuzz.coverage`), and the speeds the bins span.
    bins: Counter[str] = field(default_factory=Counter)
    speeds: tuple[str, ...] = ("-",)
    #: Anything the user should know about the run (no model, restarts, ...).
    notes: list[str] = field(default_factory=list)
    #: How the run went: (cases, seconds, distinct findings, bins hit) whenever the
    #: findings or the bins hit grew, and every :data:`TIMELINE_EVERY` cases.
    timeline: list[tuple[int, float, int, int]] = field(default_factory=list)

    @property
    def rate(self) -> float:
        return self.cases / self.elapsed if self.elapsed > 0 else 0.0

    def to_json(self) -> dict[str, Any]:
        return {
            "settings": self.settings.to_json(),
            "cases": self.cases,
            "elapsed": round(self.elapsed, 3),
            "rate": round(self.rate, 1),
            "stopped": self.stopped,
            "findings": [
                {
                    "oracle": f.oracle,
                    "signature": f.signature,
                    "case": f.case,
                    "packet": f.packet.hex(),
                    "reproduced": f.reproduced,
                    "shrunk": f.shrunk,
                }
                for f in self.findings
            ],
            "coverage": {
                "kinds": dict(self.kinds.most_common()),
                "labels": dict(self.labels.most_common()),
                "addressing": dict(self.addressing.most_common()),
                "oracles": {
                    o: {"checks": self.checks[o], "violations": self.violations[o]} for o in ORACLES
                },
                "bins": dict(sorted(self.bins.items())),
                "never_hit": never_hit(self.bins, self.speeds),
            },
            "notes": self.notes,
            "timeline": [
                {"cases": c, "seconds": round(t, 3), "findings": f, "bins_hit": b}
                for c, t, f, b in self.timeline
            ],
        }

    def lines(self) -> list[str]:
        s = self.settings
        out = [
            f"fuzzed {s.target} against the {s.contract} contract (seed {s.seed}): "
            f"{self.cases} cases in {self.elapsed:.1f} s, {self.rate:.0f} cases/s; "
            f"stopped: {self.stopped}",
            f"findings: {len(self.findings)} distinct "
            f"({sum(self.violations.values())} violations in all)",
        ]
        for f in self.findings:
            state = (
                "shrunk" if f.shrunk else "not reproduced" if f.reproduced is False else "as found"
            )
            out.append(
                f"  {f.oracle:<9} {f.signature:<44} case {f.case:<7} {state}: {f.packet.hex()[:48]}"
            )
        out.append("coverage:")
        out.append("  oracles     " + _oracle_text(self.checks, self.violations))
        for title, counter in (
            ("kinds", self.kinds),
            ("made as", self.labels),
            ("addressed", self.addressing),
        ):
            out.append(f"  {title:<11} " + ", ".join(f"{k} {v}" for k, v in counter.most_common()))
        missed = never_hit(self.bins, self.speeds)
        worth = len(space(self.speeds))
        out.append(
            f"  bins        {worth - len(missed)} of {worth} hit (kind x outcome x speed x "
            f"length x address); never hit: "
            + (", ".join(missed[:6]) or "none")
            + (f" and {len(missed) - 6} more (--json lists them)" if len(missed) > 6 else "")
        )
        out.extend(f"note: {note}" for note in self.notes)
        return out


def _oracle_text(checks: Counter[str], violations: Counter[str]) -> str:
    return ", ".join(f"{o} {checks[o]} checks/{violations[o]} violations" for o in ORACLES)
