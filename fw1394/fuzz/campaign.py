"""A fuzzing campaign: generate cases, run them, keep each distinct finding, report.

The loop is kept lean (a case costs tens of microseconds in-process): cases
are bytes from :class:`~fw1394.fuzz.generate.Generator`, decoded once, and
everything else (deduplication, coverage counts) is a dictionary update.
Findings are shrunk after the run, on a fresh node when the target can give
one: in-process always, a remote node when a restart hook brings it up again
(:mod:`fw1394.fuzz.restart`). A :class:`~fw1394.fuzz.findings.Store` gets each
finding as it is found, so a campaign that is stopped or killed keeps them.
"""

from __future__ import annotations

import random
import signal
import time
from collections.abc import Callable, Iterator
from contextlib import AbstractContextManager, contextmanager
from dataclasses import replace
from typing import Any, Protocol

from fw1394.fuzz import corpus
from fw1394.fuzz.coverage import bin_name, length_class
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.generate import Generator
from fw1394.fuzz.judge import Violation
from fw1394.fuzz.report import TIMELINE_EVERY, Report
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
from fw1394.packets.nodeid import LOCAL_BUS, bus_of, is_broadcast, phy_of
from fw1394.progress import Progress

#: Cases between two looks at the clock and the progress bar.
_STRIDE = 64
#: Replays allowed per finding on a node that cannot be restarted (each replay
#: runs on a node that has seen everything before, so it rarely pays).
_REMOTE_SHRINK_BUDGET = 20
#: The share of ``--duration`` kept for shrinking once there is something to shrink.
SHRINK_SHARE = 0.2
#: Seconds between two writes of the report while the campaign runs.
_REPORT_EVERY_S = 5.0


class Sink(Protocol):
    """Where a campaign keeps its findings and report as they come (a
    :class:`~fw1394.fuzz.findings.Store`, or a worker's way to its parent)."""

    def put(self, finding: Finding) -> object: ...

    def report(self, data: dict[str, Any]) -> None: ...


class Terminated(KeyboardInterrupt):
    """The process was asked to end (SIGTERM): stop, keep what was found as found."""


@contextmanager
def on_sigterm(handler: Callable[[int, Any], None]) -> Iterator[None]:
    """``handler`` takes SIGTERM inside, the previous one after (in the main thread;
    elsewhere the caller handles signals)."""
    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def _raise_terminated(signum: int, frame: object) -> None:
    raise Terminated


def terminable() -> AbstractContextManager[None]:
    """SIGTERM (``timeout``, a service manager) ends a campaign as Ctrl-C does, but at
    once: no shrinking, the findings saved as found."""
    return on_sigterm(_raise_terminated)


def run(
    settings: Settings,
    progress: Progress | None = None,
    *,
    restart: str | RestartHook | None = None,
    worker: int = 0,
    store: Sink | None = None,
) -> Report:
    """Fuzz the target of ``settings`` until a limit; the report (findings shrunk).

    With a ``duration``, the whole run, shrinking included, ends by then:
    fuzzing stops :data:`SHRINK_SHARE` of it early once a finding waits to be
    shrunk, and shrinking stops at the end (the findings left are kept as
    found). ``restart`` (a shell command, ``{worker}`` standing for ``worker``,
    or a callable) brings up a fresh remote node: after a wedge or a death, and
    before every replay while shrinking. ``store`` gets each finding when it is
    found and again when shrunk, and the report as it grows. Raises
    :class:`~fw1394.fuzz.restart.TargetUnreachable` when the node never answers.
    """
    start = time.monotonic()
    deadline = start + settings.duration if settings.duration else None
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
    live = _Live(report, store, start)
    try:
        _loop(trial, settings, seeds, live, progress, deadline)
    finally:
        if progress is not None:
            progress.close()
    if fresh_starts(target) and not target.restartable and report.checks["restarts"]:
        report.notes.append(f"the node was restarted {report.checks['restarts']} times")
    if report.stopped.startswith("terminated"):
        report.notes.append("terminated: the findings are as found, not shrunk")
    else:
        _shrink_all(report, settings, trial, live, progress, deadline)
    report.elapsed = time.monotonic() - start
    trial.target.close()
    return report


class _Live:
    """The report of a running campaign, and where it is kept up to date."""

    def __init__(self, report: Report, store: Sink | None, start: float) -> None:
        self.report = report
        self.store = store
        self.start = start
        self._next = start + _REPORT_EVERY_S

    def found(self, finding: Finding) -> None:
        if self.store is not None:
            self.store.put(finding)
            self.write()

    def write(self, *, when_due: bool = False) -> None:
        if self.store is None:
            return
        now = time.monotonic()
        if when_due and now < self._next:
            return
        self._next = now + _REPORT_EVERY_S
        self.report.elapsed = now - self.start
        self.store.report(self.report.to_json())


def _shrink_all(
    report: Report,
    settings: Settings,
    trial: Trial,
    live: _Live,
    progress: Progress | None,
    deadline: float | None,
) -> None:
    """Shrink the findings one by one, each kept as soon as it is shrunk."""
    findings = report.findings
    if progress is not None and findings and settings.shrink_budget:
        progress.start(f"shrinking {len(findings)} findings", len(findings))
    try:
        for index, finding in enumerate(findings):
            if deadline is not None and time.monotonic() >= deadline:
                report.notes.append(
                    f"--duration reached while shrinking: {len(findings) - index} findings "
                    "are as found"
                )
                break
            counted = _Counted(progress, index, len(findings), settings.shrink_budget)
            findings[index] = _shrunk(finding, settings, trial, counted, deadline)
            live.found(findings[index])
            if progress is not None and counted.replays:
                progress.note(_shrink_line(findings[index], counted.replays))
    except Terminated:
        report.notes.append("terminated while shrinking: the remaining findings are as found")
    except KeyboardInterrupt:
        # A second Ctrl-C: keep the rest as found rather than lose them.
        report.notes.append("shrinking interrupted: the remaining findings are as found")
    except TargetGone as gone:
        report.notes.append(f"shrinking stopped, the remaining findings are as found: {gone}")
    finally:
        if progress is not None and findings and settings.shrink_budget:
            done = sum(1 for f in findings if f.shrunk)
            progress.finish(f"{done} of {len(findings)} shrunk")


def _shrink_line(finding: Finding, replays: int) -> str:
    if finding.shrunk:
        packets = len(finding.stream)
        state = f"shrunk to {packets} packet{'s' if packets != 1 else ''}"
    else:
        state = "not reproduced" if finding.reproduced is False else "as found"
    return f"  {finding.oracle} {finding.signature}: {state} ({replays} replays)"


class _Counted:
    """Shows the replays of one finding's shrinking on the progress bar."""

    def __init__(self, progress: Progress | None, index: int, count: int, budget: int) -> None:
        self.progress, self.index, self.count, self.budget = progress, index, count, budget
        self.replays = 0

    def __call__(self) -> None:
        self.replays += 1
        if self.progress is not None:
            self.progress.update(
                self.index, f"finding {self.index + 1}: replay {self.replays}/{self.budget}"
            )


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
    live: _Live,
    progress: Progress | None,
    deadline: float | None,
) -> None:
    report = live.report
    target = trial.target
    generator = Generator(target.node_id, trial.model, random.Random(settings.seed), seeds)
    found: dict[tuple[str, str], Finding] = {}
    kinds, labels, addressing = report.kinds, report.labels, report.addressing
    speed_of = getattr(target, "speed_name_of", None)
    report.speeds = _campaign_speeds(settings) if speed_of is not None else ("-",)
    limit = settings.max_cases
    start = time.monotonic()
    # Fuzzing ends early enough to leave time for shrinking what it found.
    duration = settings.duration or 0.0
    reserve = duration * SHRINK_SHARE if settings.shrink_budget else 0.0
    cases = 0
    report.stopped = "running"
    if progress is not None:
        progress.start("fuzzing", limit, duration=settings.duration)
    first = trial.sweep()
    if first and not target.restartable:
        report.notes.append(
            "the node's registers differed from a freshly powered-up model before the first "
            "case: restart the node before a campaign, or leave out --model"
        )
    _record(first, trial, settings, found, live, 0)
    _sample(report, 0, 0.0, len(found), always=True)
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
                report.cases = cases
                new = _record(violations, trial, settings, found, live, cases)
            if trial.broken:
                record = _recover(trial, settings, report)
                for key in new:
                    if record is not None:
                        found[key].restarts.append(record.to_json())
                        live.found(found[key])
            if cases % _STRIDE == 0:
                now = time.monotonic()
                _sample(report, cases, now - start, len(found))
                if deadline is not None and now >= deadline - (reserve if found else 0.0):
                    report.stopped = "duration"
                    break
                report.cases = cases
                live.write(when_due=True)
                if progress is not None:
                    progress.update(cases, _rate(cases, now - start, len(found)))
        else:
            report.stopped = "max-cases"
    except TargetGone as gone:
        report.stopped = f"target gone ({gone})"
    except Terminated:
        report.stopped = "terminated (SIGTERM)"
    except KeyboardInterrupt:
        report.stopped = "interrupted"
    report.cases = cases
    report.checks.update(trial.checks)
    report.findings = list(found.values())
    _sample(report, cases, time.monotonic() - start, len(found), always=True)
    if progress is not None:
        elapsed = time.monotonic() - start
        progress.update(cases, _rate(cases, elapsed, len(found)), force=True)
        progress.finish(f"{_rate(cases, elapsed, len(found))}; stopped: {report.stopped}")
    live.write()


def _sample(
    report: Report, cases: int, seconds: float, findings: int, *, always: bool = False
) -> None:
    """A point of the timeline when something grew (or :data:`TIMELINE_EVERY` cases on)."""
    timeline, hit = report.timeline, len(report.bins)
    if timeline:
        last_cases, _, last_findings, last_hit = timeline[-1]
        grew = findings != last_findings or hit != last_hit
        if not (always or grew or cases - last_cases >= TIMELINE_EVERY):
            return
        if last_cases == cases:
            timeline.pop()
    timeline.append((cases, seconds, findings, hit))


def _rate(cases: int, elapsed: float, findings: int) -> str:
    rate = cases / elapsed if elapsed > 0 else 0.0
    return f"cases, {rate:.0f}/s, {findings} findings"


def _record(
    violations: list[Violation],
    trial: Trial,
    settings: Settings,
    found: dict[tuple[str, str], Finding],
    live: _Live,
    case: int,
) -> list[tuple[str, str]]:
    """Count ``violations``, keep the new ones as findings; their keys."""
    report = live.report
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
        report.findings.append(found[key])
        live.found(found[key])
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


def _shrunk(
    finding: Finding,
    settings: Settings,
    trial: Trial,
    counted: Callable[[], None],
    deadline: float | None,
) -> Finding:
    target = trial.target
    replay = replayer(settings, target, counted)
    if fresh_starts(target):
        shrunk = shrink(finding, replay, settings.shrink_budget, deadline=deadline)
        # The evidence of the shrunk stream is one more replay: not past the deadline.
        in_time = deadline is None or time.monotonic() < deadline
        return described(shrunk, settings, target) if shrunk.shrunk and in_time else shrunk
    # A remote node cannot start afresh: whatever its state has become stays, so only
    # a silence finding (which depends on the packet alone) is shrunk, from the last
    # batch; the whole stream stays in every other reproducer.
    if finding.oracle != "silence":
        return finding
    stream = finding.stream
    last = max((i for i, e in enumerate(stream) if e.role == "case"), default=0)
    budget = min(settings.shrink_budget, _REMOTE_SHRINK_BUDGET)
    tried = shrink(replace(finding, stream=stream[last:]), replay, budget, deadline=deadline)
    return tried if tried.reproduced else replace(finding, reproduced=tried.reproduced)


def replayer(
    settings: Settings, target: Target, counted: Callable[[], None] | None = None
) -> Callable[[list[Entry]], set[tuple[str, str]]]:
    """Replays a stream on ``target``: restarted first when it can be, as is otherwise
    (``counted`` is told of each replay)."""

    def replay(stream: list[Entry]) -> set[tuple[str, str]]:
        if counted is not None:
            counted()
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
    if is_broadcast(destination):
        return "broadcast"
    if phy_of(destination) != phy_of(node_id):
        return "other-node"
    return "ours" if bus_of(destination) in (LOCAL_BUS, bus_of(node_id)) else "other-bus"
