"""The hypothesis engine: cases drawn by hypothesis, findings shrunk by hypothesis.

Slower than the fast generator (a draw costs milliseconds), but the cases come
from the exported strategies and each finding is minimised by hypothesis (the
simplest values the strategies can draw), then by the delta-debugging
shrinker (the fewest packets). Each example is a short list of cases sent to
a fresh node (in-process targets only), so it repeats exactly.

Hypothesis stops at the first bug of a run and shrinks it; the engine then
starts another run that lets the known ones pass, until the case budget or
the time is spent.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

from hypothesis import HealthCheck, Phase, given, seed
from hypothesis import settings as hypothesis_settings
from hypothesis import strategies as st

from fw1394.errors import Error
from fw1394.fuzz.campaign import replayer
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.judge import Violation
from fw1394.fuzz.report import Report
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.strategies import fuzz_cases
from fw1394.fuzz.target import Target
from fw1394.fuzz.targets import open_target, open_trial, target_kind
from fw1394.fuzz.trial import Entry

#: Cases per example at most: enough for bugs that need some state first.
MAX_CASES_PER_EXAMPLE = 8
#: Examples per hypothesis run (each run finds at most one new bug).
EXAMPLES_PER_RUN = 400


class _Found(Error):
    """Raised inside the property to make hypothesis shrink towards this violation."""


@dataclass
class _Budget:
    cases: int | None
    deadline: float | None
    spent: int = 0
    known: dict[tuple[str, str], Finding] = field(default_factory=dict)

    @property
    def exhausted(self) -> bool:
        over = self.cases is not None and self.spent >= self.cases
        return over or (self.deadline is not None and time.monotonic() >= self.deadline)


def run(settings: Settings) -> Report:
    """Fuzz an in-process target with hypothesis; the report and its shrunk findings."""
    if settings.scheme != "inproc":
        raise SettingsError("the hypothesis engine needs a target it can restart (inproc:)")
    target = open_target(settings)
    report = Report(settings)
    start = time.monotonic()
    budget = _Budget(settings.max_cases, start + settings.duration if settings.duration else None)
    cases = st.lists(
        fuzz_cases(target.node_id, kind=target_kind(settings)),
        min_size=1,
        max_size=MAX_CASES_PER_EXAMPLE,
    )
    round_number = 0
    while not budget.exhausted:
        if not _one_run(settings, target, cases, budget, report, settings.seed + round_number):
            break
        round_number += 1
    report.cases = budget.spent
    report.elapsed = time.monotonic() - start
    report.stopped = "max-cases" if settings.max_cases is not None else "duration"
    # Hypothesis minimises the drawn values; delta debugging then drops the packets
    # (probes and read-backs included) the violation does not need.
    replay = replayer(settings, target)
    report.findings = [shrink(f, replay, settings.shrink_budget) for f in budget.known.values()]
    target.close()
    return report


def _one_run(
    settings: Settings,
    target: Target,
    cases: st.SearchStrategy[list[bytes]],
    budget: _Budget,
    report: Report,
    run_seed: int,
) -> bool:
    """One hypothesis run; True when it found a new bug (so another run may find more)."""
    last: dict[tuple[str, str], tuple[Violation, list[Entry], int]] = {}

    examples = EXAMPLES_PER_RUN
    if budget.cases is not None:
        # An example holds about half the most cases a list may have.
        examples = max(1, min(examples, (budget.cases - budget.spent) * 2 // MAX_CASES_PER_EXAMPLE))

    @seed(run_seed)
    @hypothesis_settings(
        max_examples=examples,
        database=None,
        deadline=None,
        derandomize=False,
        report_multiple_bugs=False,
        suppress_health_check=list(HealthCheck),
        phases=[Phase.generate, Phase.shrink],
    )
    @given(cases)
    def example(raws: list[bytes]) -> None:
        target.restart()
        trial = open_trial(settings, target)
        try:
            for number, raw in enumerate(raws, 1):
                budget.spent += 1
                violations = trial.case(raw, "hypothesis")
                packet = trial.last_wire.packet
                report.kinds[packet.kind if packet is not None else "undecodable"] += 1
                for violation in violations:
                    report.violations[violation.oracle] += 1
                    key = (violation.oracle, violation.signature)
                    if key not in budget.known:
                        last[key] = (violation, list(trial.stream), number)
                        raise _Found(f"{key[0]}:{key[1]}")
                if trial.broken:
                    return
        finally:
            report.checks.update(trial.checks)

    try:
        example()
    except (_Found, BaseExceptionGroup) as error:
        found = _found_in(error)
        if found is None:
            raise
        oracle, signature = str(found).split(":", 1)
        violation, stream, number = last[(oracle, signature)]
        budget.known[(oracle, signature)] = Finding(
            oracle=oracle,
            signature=signature,
            target=settings.target,
            settings=settings.to_json(),
            expected=violation.expected,
            observed=violation.observed,
            case=budget.spent,
            label=f"hypothesis (case {number} of its example)",
            stream=stream,
            reproduced=found is error,
            shrunk=found is error,
        )
        return True
    return False


def _found_in(error: BaseException) -> _Found | None:
    """The violation hypothesis shrank to; inside a group when the replay was flaky
    (a node whose state outlives a restart)."""
    if isinstance(error, _Found):
        return error
    if isinstance(error, BaseExceptionGroup):
        for inner in error.exceptions:
            found = _found_in(inner)
            if found is not None:
                return found
    return None
