"""A fuzzing campaign: generate cases, run them, keep each distinct finding, report.

The loop is kept lean (a case costs tens of microseconds in-process): cases
are bytes from :class:`~fw1394.fuzz.generate.Generator`, decoded once, and
everything else (deduplication, coverage counts) is a dictionary update.
Findings are shrunk after the run, on a fresh node when the target can give
one: in-process always, a remote node when a restart hook brings it up again
(:mod:`fw1394.fuzz.restart`).
"""

from __future__ import annotations

import random
import time
from collections.abc import Callable
from dataclasses import replace

from fw1394.fuzz import corpus
from fw1394.fuzz.coverage import bin_name, length_class
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.judge import Violation
from fw1394.fuzz.progress import Progress
from fw1394.fuzz.report import Report
from fw1394.fuzz.restart import (
    RestartHook,
    RestartingTarget,
    RestartRecord,
    TargetUnreachable,
    fresh_starts,
    hook_of,
    probe_wire,
    wait_until_answers,
)
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.target import Target, TargetGone
from fw1394.fuzz.targets import open_target, open_trial, target_kind
from fw1394.fuzz.trial import Entry, Trial
from fw1394.packets import AsyncPacket

#: Cases between two looks at the clock and the progress bar.
_STRIDE = 64
#: Replays allowed per finding on a node that cannot be restarted (each replay
#: runs on a node that has seen everything before, so it rarely pays).
_REMOTE_SHRINK_BUDGET = 20


def run(
    settings: Settings,
    progress: Progress | None = None,
    *,
    restart: str | RestartHook | None = None,
    worker: int = 0,
) -> Report:
    """Fuzz the target of ``settings`` until a limit; the report (findings shrunk).

    ``restart`` (a shell command, ``{worker}`` standing for ``worker``, or a
    callable) brings up a fresh remote node: after a wedge or a death, and
    before every replay while shrinking. Raises
    :class:`~fw1394.fuzz.restart.TargetUnreachable` when the node never answers.
    """
    seeds = corpus.load(settings.corpus)
    target = open_campaign_target(settings, hook_of(restart, worker))
    try:
        _check_reachable(target, settings)
    except BaseException:
        target.close()
        raise
    trial = open_trial(settings, target)
    report = Report(settings)
    if fresh_starts(target) and not target.restartable:
        report.notes.append("restart hook: the node is brought up afresh after a wedge or death")
    if target_kind(settings) is None:
        report.notes.append("no --model: replies are checked for presence and routing only")
    try:
        _loop(trial, settings, seeds, report, progress)
    finally:
        if progress is not None:
            progress.close()
    if fresh_starts(target) and not target.restartable and report.checks["restarts"]:
        report.notes.append(f"the node was restarted {report.checks['restarts']} times")
    shrunk: list[Finding] = []
    try:
        for finding in report.findings:
            shrunk.append(_shrunk(finding, settings, trial))
    except KeyboardInterrupt:
        # A second Ctrl-C: keep the rest as found rather than lose them.
        report.notes.append("shrinking interrupted: the remaining findings are as found")
        report.findings = shrunk + report.findings[len(shrunk) :]
    except TargetGone as gone:
        report.notes.append(f"shrinking stopped, the remaining findings are as found: {gone}")
        report.findings = shrunk + report.findings[len(shrunk) :]
    else:
        report.findings = shrunk
    trial.target.close()
    return report


def open_campaign_target(settings: Settings, hook: RestartHook | None) -> Target:
    """The settings' target, wrapped so that ``hook`` can restart it (remote targets)."""
    if hook is None:
        return open_target(settings)
    if settings.scheme == "inproc":
        raise SettingsError("--restart is for remote targets; an in-process node restarts itself")
    return RestartingTarget(settings, hook)


def _check_reachable(target: Target, settings: Settings) -> None:
    """A remote node must answer the probe once before anything is judged."""
    if not target.needs_fence:
        return
    probe = probe_wire(settings, target.node_id)
    if wait_until_answers(target, probe, settings.dead_after):
        return
    why = f"target not reachable: {target.description} did not answer a probe"
    if fresh_starts(target):
        try:
            target.restart()
        except TargetGone as gone:
            raise TargetUnreachable(f"{why}, nor after a restart ({gone})") from None
        return
    raise TargetUnreachable(f"{why} within {settings.dead_after} s")


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
    speed_of = getattr(target, "speed_name_of", None)
    report.speeds = _campaign_speeds(settings) if speed_of is not None else ("-",)
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
            kind = packet.kind if packet is not None else "undecodable"
            kinds[kind] += 1
            labels[label] += 1
            address = _addressed(packet, target.node_id)
            addressing[address] += 1
            speed = speed_of(raw) if speed_of is not None else "-"
            report.bins[
                bin_name(kind, trial.last_outcome, speed, length_class(packet), address)
            ] += 1
            new: list[tuple[str, str]] = []
            if violations:
                new = _record(violations, trial, settings, found, report, cases)
            if trial.broken:
                record = _recover(trial, settings, report)
                for key in new:
                    if record is not None:
                        found[key].restarts.append(record.to_json())
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
) -> list[tuple[str, str]]:
    """Count ``violations``, keep the new ones as findings; their keys."""
    new = []
    for violation in violations:
        report.violations[violation.oracle] += 1
        key = (violation.oracle, violation.signature)
        if key in found:
            continue
        new.append(key)
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
    return new


def _recover(trial: Trial, settings: Settings, report: Report) -> RestartRecord | None:
    """Carry on after a crash or a wedge: a fresh node, or wait for the old one.

    The restart, when a hook made one, is returned to be kept in the finding.
    """
    target = trial.target
    if fresh_starts(target):
        trial.restart(open_trial(settings, target).reference)
        report.checks["restarts"] += 1
        records: list[RestartRecord] = getattr(target, "records", [])
        return records[-1] if records else None
    if trial.target.problem() is not None:
        raise TargetGone(trial.target.problem() or "")
    limit = time.monotonic() + settings.dead_after
    while time.monotonic() < limit:
        trial.broken = False
        trial.sweep()
        if not trial.broken:
            return None
    raise TargetGone(f"no answer for {settings.dead_after} s")


def _shrunk(finding: Finding, settings: Settings, trial: Trial) -> Finding:
    target = trial.target
    if fresh_starts(target):
        shrunk = shrink(finding, replayer(settings, target), settings.shrink_budget)
        return described(shrunk, settings, target) if shrunk.shrunk else shrunk
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
        return {(v.oracle, v.signature) for v in replay_violations(settings, target, stream)}

    return replay


def replay_violations(settings: Settings, target: Target, stream: list[Entry]) -> list[Violation]:
    """The violations ``stream`` shows, on a fresh node when ``target`` can give one."""
    if fresh_starts(target):
        target.restart()
    fresh = open_trial(settings, target)
    return fresh.replay(stream, keep_times=target.restartable)


def described(finding: Finding, settings: Settings, target: Target) -> Finding:
    """``finding`` with the evidence of its shrunk stream (which registers, which replies)."""
    for violation in replay_violations(settings, target, finding.stream):
        if (violation.oracle, violation.signature) == finding.key:
            return replace(finding, expected=violation.expected, observed=violation.observed)
    return finding


def _campaign_speeds(settings: Settings) -> tuple[str, ...]:
    return ("S100", "S200", "S400") if settings.speed == "mixed" else (settings.speed,)


def _addressed(packet: AsyncPacket | None, node_id: int) -> str:
    destination: int | None = getattr(packet, "destination_id", None)
    if destination is None:
        return "-"
    if destination & 0x3F == 63:
        return "broadcast"
    if destination & 0x3F != node_id & 0x3F:
        return "other-node"
    return "ours" if destination >> 6 in (0x3FF, node_id >> 6) else "other-bus"
