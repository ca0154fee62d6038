"""One campaign on several worker processes: seeds derived from one, one merged report.

Worker ``i`` runs an ordinary campaign with a seed derived from the
campaign's (worker 0 keeps it) and its share of ``max_cases``, on a target of
its own: in-process each has its own node; ``{worker}`` in a remote target
spec or restart command stands for the worker number (``udp:127.0.0.1:1140{worker}``,
``bus:fuzz{worker}/0``). Each worker shrinks its own findings; the report adds
the counts up and keeps one finding per signature, the lowest worker's, so
with ``max_cases`` a run repeats exactly.
"""

from __future__ import annotations

import multiprocessing
import os
import random
import signal
import threading
import time
from collections import defaultdict
from collections.abc import Iterator
from concurrent.futures import Future, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import replace
from typing import Any

from fw1394.fuzz import campaign
from fw1394.fuzz.findings import Finding, Store, merged
from fw1394.fuzz.report import Report
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.progress import Progress
from fw1394.transport.supervision.procs import die_with_parent

#: In a target spec or restart command: the worker's number.
WORKER = "{worker}"


def worker_seed(seed: int, worker: int) -> int:
    """Worker ``worker``'s seed: ``seed`` itself for worker 0, derived for the others."""
    if worker == 0:
        return seed
    return random.Random(f"fw1394-fuzz/{seed}/{worker}").getrandbits(31)


def worker_settings(settings: Settings, worker: int, jobs: int) -> Settings:
    """The settings worker ``worker`` of ``jobs`` runs with."""
    cases = settings.max_cases
    if cases is not None:
        cases = cases // jobs + (1 if worker < cases % jobs else 0)
    return replace(
        settings,
        target=settings.target.replace(WORKER, str(worker)),
        seed=worker_seed(settings.seed, worker),
        max_cases=cases,
    )


def run(
    settings: Settings,
    jobs: int,
    *,
    restart: str | None = None,
    progress: Progress | None = None,
    store: Store | None = None,
) -> Report:
    """The campaign of ``settings`` on ``jobs`` worker processes; the merged report.

    One job runs in this process (with ``progress``); several show no progress
    bar. Either way each finding goes to ``store`` as it is found (forked workers
    send theirs to this process, which writes them).
    """
    if jobs < 1:
        raise SettingsError("jobs must be at least 1")
    remote = settings.scheme != "inproc"
    if jobs > 1 and remote and WORKER not in settings.target:
        raise SettingsError(
            "--jobs with a remote target needs {worker} in the target (one node per worker)"
        )
    start = time.monotonic()
    if jobs == 1:
        return campaign.run(worker_settings(settings, 0, 1), progress, restart=restart, store=store)
    work = [(worker_settings(settings, w, jobs), restart, w) for w in range(jobs)]
    context = _context()
    forwarded: dict[int, dict[tuple[str, str], Finding]] = defaultdict(dict)
    with _sigterm_deferred():
        pool = ProcessPoolExecutor(
            jobs, mp_context=context, initializer=_start_worker, initargs=(os.getpid(),)
        )
        with _forwarded(store, context, forwarded), pool:
            with _sigterm_held():  # the workers are forked here
                futures = [pool.submit(_work, job) for job in work]
            try:
                with _stoppable():
                    for future in futures:
                        future.exception()
            except campaign.Terminated:
                # SIGTERM reached this process only: hand it on, so that every worker
                # ends its campaign now and returns what it found, as one job would.
                for child in multiprocessing.active_children():
                    child.terminate()
        # Every worker has ended and every finding it handed on is written.
        outcomes = zip(futures, work, strict=True)
        reports = [_result(future, job[0], forwarded[job[2]]) for future, job in outcomes]
        return merge(settings, reports, time.monotonic() - start)


# SIGTERM in a campaign of several processes. Raised as an exception at an arbitrary
# point it breaks the pool or a queue for good: in a worker just after it took a
# queue's lock, the lock is never given back and the next writer waits forever; in
# the fork's own clean-up it is ignored and the worker fuzzes on to the end of its
# --duration; before a worker's campaign begins it kills the worker and breaks the
# pool; in this process while it starts the pool, no worker hears of it. So the
# signal is only noted, and raised as Terminated where an exception is harmless:
# inside a worker's campaign (not while it hands on a finding) and while this
# process waits for the workers.

#: SIGTERM came to this process (this campaign's, or a worker forked from it).
_stop_requested = False
#: Whether SIGTERM raises Terminated right now.
_stop_raises = False


def _on_sigterm(signum: int, frame: object) -> None:
    global _stop_requested, _stop_raises
    _stop_requested = True
    if _stop_raises:
        _stop_raises = False  # once: what runs after it must run whole
        raise campaign.Terminated


@contextmanager
def _sigterm_deferred() -> Iterator[None]:
    """SIGTERM is noted, not raised, while inside (and in workers forked inside)."""
    global _stop_requested, _stop_raises
    _stop_requested = _stop_raises = False
    with campaign.on_sigterm(_on_sigterm):
        yield


@contextmanager
def _stoppable() -> Iterator[None]:
    """SIGTERM raises Terminated inside, at once if it came before."""
    global _stop_raises
    if _stop_requested:
        raise campaign.Terminated
    _stop_raises = True
    try:
        yield
    finally:
        _stop_raises = False


@contextmanager
def _unstoppable() -> Iterator[None]:
    """SIGTERM waits until the end of the block (a message written whole, a lock given back)."""
    global _stop_raises
    raises, _stop_raises = _stop_raises, False
    try:
        yield
    finally:
        _stop_raises = raises
    if raises and _stop_requested:
        _stop_raises = False
        raise campaign.Terminated


@contextmanager
def _sigterm_held() -> Iterator[None]:
    """SIGTERM held back from this thread, and from workers forked inside until their
    initializer: a forked child's interpreter forgets a signal that came before its own
    after-fork clean-up (the worker would fuzz on), but not one held back for it."""
    held = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, held)


def _start_worker(parent: int) -> None:
    # A worker left behind by a killed campaign goes too: what it found so far is
    # written already, and nothing would take the rest.
    die_with_parent(parent, signal.SIGKILL)
    signal.signal(signal.SIGTERM, _on_sigterm)  # forked workers have it already
    signal.pthread_sigmask(signal.SIG_UNBLOCK, {signal.SIGTERM})


#: Where forked workers put each finding as they find it (inherited, not pickled).
_FOUND: Any = None


class _Forwarding:
    """A worker's store: each finding goes to the campaign's process, which writes it."""

    def __init__(self, worker: int) -> None:
        self.worker = worker

    def put(self, finding: Finding) -> None:
        with _unstoppable():
            _FOUND.put((self.worker, finding))

    def report(self, data: dict[str, Any]) -> None:
        pass  # the merged report is written when the workers end


@contextmanager
def _forwarded(
    store: Store | None, context: Any, forwarded: dict[int, dict[tuple[str, str], Finding]]
) -> Iterator[None]:
    """Workers forked inside hand their findings to ``store`` as they find them (and to
    ``forwarded``, by worker)."""
    global _FOUND
    if store is None or context.get_start_method() != "fork":
        yield
        return
    queue = context.SimpleQueue()

    def write() -> None:
        while (item := queue.get()) is not None:
            worker, finding = item
            store.put(finding)
            forwarded[worker][finding.key] = finding

    writer = threading.Thread(target=write, name="findings-writer", daemon=True)
    writer.start()
    _FOUND = queue
    try:
        yield
    finally:
        _FOUND = None
        queue.put(None)
        writer.join()


def _result(
    future: Future[Report], settings: Settings, forwarded: dict[tuple[str, str], Finding]
) -> Report:
    """The worker's report. Stopped by SIGTERM outside its campaign's loop (before it
    began, or as it ended), a report of the findings it handed on: they are written,
    so the report names them."""
    try:
        return future.result()
    except campaign.Terminated:
        report = Report(settings)
        report.stopped = "terminated (SIGTERM)"
        report.findings = list(forwarded.values())
        report.notes.append("terminated: the findings are as found, not shrunk")
        return report


def _work(job: tuple[Settings, str | None, int]) -> Report:
    settings, restart, worker = job
    sink = _Forwarding(worker) if _FOUND is not None else None
    with _stoppable():
        return campaign.run(settings, restart=restart, worker=worker, store=sink)


def _context() -> multiprocessing.context.BaseContext:
    # Forking skips re-importing fw1394 in every worker; elsewhere, spawn.
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def merge(settings: Settings, reports: list[Report], elapsed: float) -> Report:
    """One report of the workers' ``reports`` (in worker order), ``elapsed`` seconds in all."""
    report = Report(settings)
    report.elapsed = elapsed
    report.cases = sum(r.cases for r in reports)
    reasons = list(dict.fromkeys(r.stopped for r in reports))
    report.stopped = "; ".join(reasons)
    for part in reports:
        report.kinds.update(part.kinds)
        report.labels.update(part.labels)
        report.addressing.update(part.addressing)
        report.checks.update(part.checks)
        report.violations.update(part.violations)
        report.bins.update(part.bins)
        report.speeds = part.speeds
        report.notes.extend(n for n in part.notes if n not in report.notes)
    report.findings = merged(*(r.findings for r in reports))
    report.notes.append(f"{len(reports)} workers, seeds {', '.join(_seeds(reports))}")
    return report


def _seeds(reports: list[Report]) -> list[str]:
    return [str(r.settings.seed) for r in reports]
