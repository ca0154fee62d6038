"""A fuzzing campaign: generate cases, run them, keep each distinct finding, report.

The loop is kept lean (a case costs tens of microseconds in-process): cases
are bytes from :class:`~fw1394.fuzz.generate.Generator`, decoded once, and
everything else (deduplication, coverage counts) is a dictionary update.
Findings are shrunk after the run, on a fresh node when the target can give
one.
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import replace

from fw1394.fuzz import corpus
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.judge import Violation
from fw1394.fuzz.progress import Progress
from fw1394.fuzz.report import Report
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.target import Target, TargetGone
from fw1394.fuzz.targets import open_trial, target_kind
from fw1394.fuzz.trial import Entry, Trial
from fw1394.packets import AsyncPacket

#: Cases between two looks at the clock and the progress bar.
_STRIDE = 64
#: Replays allowed per finding on a node that cannot be restarted (each replay
#: runs on a node that has seen everything before, so it rarely pays).
_REMOTE_SHRINK_BUDGET = 20


def run(settings: Settings, progress: Progress | None = None) -> Report:
    """Fuzz the target of ``settings`` until a limit; the report (findings shrunk)."""
    seeds = corpus.load(settings.corpus)
    trial = open_trial(settings)
    report = Report(settings)
    if target_kind(settings) is None:
        report.notes.append("no --model: replies are checked for presence and routing only")
    try:
        _loop(trial, settings, seeds, report, progress)
    finally:
        if progress is not None:
            progress.close()
    shrunk: list[Finding] = []
    try:
        for finding in report.findings:
            shrunk.append(_shrunk(finding, settings, trial))
    except KeyboardInterrupt:
        # A second Ctrl-C: keep the rest as found rather than lose them.
        report.notes.append("shrinking interrupted: the remaining findings are as found")
        report.findings = shrunk + report.findings[len(shrunk) :]
    else:
        report.findings = shrunk
    trial.target.close()
    return report


def _loop(
    trial: Trial,
    settings: Settings,
    seeds: list[bytes],
    report: Report,
    progress: Progress | None,
) -> None:
    target = trial.target
    generator = Generator(target.node_id, trial.model, random.Random(settings.seed), seeds)
    found: dict[tuple[str, str], Finding] = {}
    kinds, labels, addressing = report.kinds, report.labels, report.addressing
    limit = settings.max_cases
    start = time.monotonic()
    deadline = start + settings.duration if settings.duration else None
    cases = 0
    report.stopped = "max-cases"
    first = trial.sweep()
    if first and not target.restartable:
        report.notes.append(
            "the node's registers differed from a freshly powered-up model before the first "
            "case: restart the node before a campaign, or leave out --model"
        )
    _record(first, trial, settings, found, report, 0)
    try:
        while limit is None or cases < limit:
            raw, label = generator.case()
            cases += 1
            violations = trial.case(raw, label)
            packet = trial.last_wire.packet
            kinds[packet.kind if packet is not None else "undecodable"] += 1
            labels[label] += 1
            addressing[_addressed(packet, target.node_id)] += 1
            if violations:
                _record(violations, trial, settings, found, report, cases)
            if trial.broken:
                _recover(trial, settings, report)
            if cases % _STRIDE == 0:
                if deadline is not None and time.monotonic() >= deadline:
                    report.stopped = "duration"
                    break
                if progress is not None:
                    progress.update(cases, len(found))
    except TargetGone as gone:
        report.stopped = f"target gone ({gone})"
    except KeyboardInterrupt:
        report.stopped = "interrupted"
    report.cases = cases
    report.elapsed = time.monotonic() - start
    report.checks.update(trial.checks)
    report.findings = list(found.values())
    if progress is not None:
        progress.update(cases, len(found), force=True)


def _record(
    violations: list[Violation],
    trial: Trial,
    settings: Settings,
    found: dict[tuple[str, str], Finding],
    report: Report,
    case: int,
) -> None:
    for violation in violations:
        report.violations[violation.oracle] += 1
        key = (violation.oracle, violation.signature)
        if key in found:
            continue
        found[key] = Finding(
            oracle=violation.oracle,
            signature=violation.signature,
            target=settings.target,
            settings=settings.to_json(),
            expected=violation.expected,
            observed=violation.observed,
            case=case,
            label=next((e.label for e in reversed(trial.stream) if e.role == "case"), ""),
            stream=list(trial.stream),
        )


def _recover(trial: Trial, settings: Settings, report: Report) -> None:
    """Carry on after a crash or a wedge: a fresh node, or wait for the old one."""
    if trial.target.restartable:
        trial.restart(open_trial(settings, trial.target).reference)
        report.checks["restarts"] += 1
        return
    if trial.target.problem() is not None:
        raise TargetGone(trial.target.problem() or "")
    limit = time.monotonic() + settings.dead_after
    while time.monotonic() < limit:
        trial.broken = False
        trial.sweep()
        if not trial.broken:
            return
    raise TargetGone(f"no answer for {settings.dead_after} s")


def _shrunk(finding: Finding, settings: Settings, trial: Trial) -> Finding:
    target = trial.target
    if target.restartable:
        return shrink(finding, replayer(settings, target), settings.shrink_budget)
    # A remote node cannot start afresh: whatever its state has become stays, so only
    # a silence finding (which depends on the packet alone) is shrunk, from the last
    # batch; the whole stream stays in every other reproducer.
    if finding.oracle != "silence":
        return finding
    stream = finding.stream
    last = max((i for i, e in enumerate(stream) if e.role == "case"), default=0)
    budget = min(settings.shrink_budget, _REMOTE_SHRINK_BUDGET)
    tried = shrink(replace(finding, stream=stream[last:]), replayer(settings, target), budget)
    return tried if tried.reproduced else replace(finding, reproduced=tried.reproduced)


def replayer(settings: Settings, target: Target) -> Callable[[list[Entry]], set[tuple[str, str]]]:
    """Replays a stream on ``target``: restarted first when it can be, as is otherwise."""

    def replay(stream: list[Entry]) -> set[tuple[str, str]]:
        if target.restartable:
            target.restart()
        fresh = open_trial(settings, target)
        violations = fresh.replay(stream, keep_times=target.restartable)
        return {(v.oracle, v.signature) for v in violations}

    return replay


def _addressed(packet: AsyncPacket | None, node_id: int) -> str:
    destination: int | None = getattr(packet, "destination_id", None)
    if destination is None:
        return "-"
    if destination & 0x3F == 63:
        return "broadcast"
    if destination & 0x3F != node_id & 0x3F:
        return "other-node"
    return "ours" if destination >> 6 in (0x3FF, node_id >> 6) else "other-bus"
