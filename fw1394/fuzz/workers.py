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
import random
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import replace

from fw1394.fuzz import campaign
from fw1394.fuzz.findings import Store, merged
from fw1394.fuzz.report import Report
from fw1394.fuzz.settings import Settings, SettingsError
from fw1394.progress import Progress

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

    One job runs in this process (with ``progress``, its findings kept in ``store``
    as they are found); several show no progress bar and hand their findings over
    when they end.
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
    with ProcessPoolExecutor(jobs, mp_context=_context()) as pool:
        reports = list(pool.map(_work, work))
    return merge(settings, reports, time.monotonic() - start)


def _work(job: tuple[Settings, str | None, int]) -> Report:
    settings, restart, worker = job
    return campaign.run(settings, restart=restart, worker=worker)


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
