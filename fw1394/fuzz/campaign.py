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
from fw1394.fuzz.session import Entry, Session
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.target import Target, TargetGone
from fw1394.fuzz.targets import open_session, target_kind
from fw1394.packets import AsyncPacket

#: Cases between two looks at the clock and the progress bar.
_STRIDE = 64
#: Replays allowed per finding on a node that cannot be restarted (each replay
#: runs on a node that has seen everything before, so it rarely pays).
_REMOTE_SHRINK_BUDGET = 20


def run(settings: Settings, progress: Progress | None = None) -> Report:
    """Fuzz the target of ``settings`` until a limit; the report (findings shrunk)."""
    seeds = corpus.load(settings.corpus)
    session = open_session(settings)
    report = Report(settings)
    if target_kind(settings) is None:
        report.notes.append("no --model: replies are checked for presence and routing only")
    try:
        _loop(session, settings, seeds, report, progress)
    finally:
        if progress is not None:
            progress.close()
    shrunk: list[Finding] = []
    try:
        for finding in report.findings:
            shrunk.append(_shrunk(finding, settings, session))
    except KeyboardInterrupt:
        # A second Ctrl-C: keep the rest as found rather than lose them.
        report.notes.append("shrinking interrupted: the remaining findings are as found")
        report.findings = shrunk + report.findings[len(shrunk) :]
    else:
        report.findings = shrunk
    session.target.close()
    return report


def _loop(
    session: Session,
    settings: Settings,
    seeds: list[bytes],
    report: Report,
    progress: Progress | None,
) -> None:
    target = session.target
    generator = Generator(target.node_id, session.model, random.Random(settings.seed), seeds)
    found: dict[tuple[str, str], Finding] = {}
    kinds, labels, addressing = report.kinds, report.labels, report.addressing
    limit = settings.max_cases
    start = time.monotonic()
    deadline = start + settings.duration if settings.duration else None
    cases = 0
    report.stopped = "max-cases"
    first = session.sweep()
    if first and not target.restartable:
        report.notes.append(
            "the node's registers differed from a freshly powered-up model before the first "
            "case: restart the node before a campaign, or leave out --model"
        )
    _record(first, session, settings, found, report, 0)
    try:
        while limit is None or cases < limit:
            raw, label = generator.case()
            cases += 1
            violations = session.case(raw, label)
            packet = session.last_wire.packet
            kinds[packet.kind if packet is not None else "undecodable"] += 1
            labels[label] += 1
            addressing[_addressed(packet, target.node_id)] += 1
            if violations:
                _record(violations, session, settings, found, report, cases)
            if session.broken:
                _recover(session, settings, report)
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
    report.checks.update(session.checks)
    report.findings = list(found.values())
    if progress is not None:
        progress.update(cases, len(found), force=True)


def _record(
    violations: list[Violation],
    session: Session,
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
            label=next((e.label for e in reversed(session.stream) if e.role == "case"), ""),
            stream=list(session.stream),
        )


def _recover(session: Session, settings: Settings, report: Report) -> None:
    """Carry on after a crash or a wedge: a fresh node, or wait for the old one."""
    if session.target.restartable:
        session.restart(open_session(settings, session.target).reference)
        report.checks["restarts"] += 1
        return
    if session.target.problem() is not None:
        raise TargetGone(session.target.problem() or "")
    limit = time.monotonic() + settings.dead_after
    while time.monotonic() < limit:
        session.broken = False
        session.sweep()
        if not session.broken:
            return
    raise TargetGone(f"no answer for {settings.dead_after} s")


def _shrunk(finding: Finding, settings: Settings, session: Session) -> Finding:
    target = session.target
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
        fresh = open_session(settings, target)
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
