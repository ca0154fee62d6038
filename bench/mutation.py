"""Mutation score: plant small defects in the library, one at a time, and count the caught ones.

    python bench/mutation.py                          # every planned module (hours)
    python bench/mutation.py --sample 30              # 30 mutants per module, seeded
    python bench/mutation.py fw1394/transport/seal.py # named modules (their tests by the plan)
    python bench/mutation.py --changed HEAD~1 --budget 600   # what a change touched
    python bench/mutation.py --json                   # one JSON object for scripts

Each module is mutated by cosmic-ray (operators: comparisons, arithmetic,
boolean and unary operators, numbers, break/continue, exceptions, ...) and the
test directories that the plan below names for it run against every mutant,
in-process tests only (``-m "not process"``: a spawned child would import the
unmutated installed copy or take minutes). A mutant is *killed* when those tests
fail or time out, *survived* when they pass. Survivors are printed with their
line and diff: each is a missing test or an equivalent mutant, and
``docs/testing.md`` records the triage. The score is killed / (killed + survived).

The files are mutated in place and restored by cosmic-ray after each mutant: run
it in a checkout where nothing else is running.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import random
import sqlite3
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent

#: Module or package (relative to the repository) -> the test directories that pin it.
PLAN: dict[str, tuple[str, ...]] = {
    "fw1394/crc": ("tests/crc", "tests/packets/test_packet_vectors.py"),
    "fw1394/packets": ("tests/packets", "tests/crc"),
    "fw1394/engine": ("tests/engine",),
    "fw1394/transport/seal.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_seal.py",
    ),
    "fw1394/transport/wire.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_wire.py",
    ),
    "fw1394/transport/membership.py": (
        "tests/transport/test_bus_membership.py",
        "tests/transport/test_membership_pause.py",
    ),
    "fw1394/transport/link.py": ("tests/transport/test_link.py",),
    "fw1394/boards": ("tests/boards",),
    "fw1394/capture/formats": (
        "tests/capture/test_capture_formats.py",
        "tests/capture/test_capture_kernel.py",
        "tests/capture/test_capture_udp.py",
        "tests/capture/test_foreign_files.py",
        "tests/capture/test_robustness_captures.py",
    ),
    "fw1394/fuzz/judge.py": ("tests/fuzz/test_fuzz_oracles.py", "tests/fuzz/test_fuzz_defects.py"),
}


@dataclass
class ModuleScore:
    module: str
    killed: int = 0
    survived: int = 0
    incompetent: int = 0  # the mutant could not even be imported or run
    survivors: list[dict[str, object]] = field(default_factory=list)

    @property
    def score(self) -> float | None:
        tried = self.killed + self.survived
        return self.killed / tried if tried else None


def plan_for(paths: list[str]) -> dict[str, tuple[str, ...]]:
    """Every module file of ``paths`` with the test directories of its plan entry."""
    chosen: dict[str, tuple[str, ...]] = {}
    for wanted in paths:
        target = (ROOT / wanted).resolve()
        entry = next(
            (key for key in sorted(PLAN, key=len, reverse=True)
             if target == ROOT / key or (ROOT / key) in target.parents),
            None,
        )  # fmt: skip
        if entry is None:
            continue
        files = sorted(target.rglob("*.py")) if target.is_dir() else [target]
        for file in files:
            if file.suffix == ".py" and file.name != "__main__.py":
                chosen[str(file.relative_to(ROOT))] = PLAN[entry]
    return chosen


def changed_files(base: str) -> list[str]:
    done = subprocess.run(
        ["git", "diff", "--name-only", base, "--", "fw1394"],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        raise SystemExit(f"mutation: git cannot compare with {base!r}: {done.stderr.strip()}")
    return [line for line in done.stdout.splitlines() if (ROOT / line).exists()]


def config(module: str, tests: tuple[str, ...], timeout: float) -> str:
    command = f'{sys.executable} -m pytest -x -q -p no:cacheprovider -m "not process" ' + " ".join(
        tests
    )
    return (
        "[cosmic-ray]\n"
        f'module-path = "{module}"\n'
        f"timeout = {timeout}\n"
        "excluded-modules = []\n"
        f"test-command = {json.dumps(command)}\n\n"
        '[cosmic-ray.distributor]\nname = "local"\n'
    )


def keep_sample(session: Path, sample: int, seed: int) -> int:
    """Keep ``sample`` mutants of the session, chosen with ``seed``; how many there were."""
    with sqlite3.connect(session) as db:
        jobs = [row[0] for row in db.execute("SELECT job_id FROM work_items ORDER BY job_id")]
        if 0 < sample < len(jobs):
            drop = set(jobs) - set(random.Random(seed).sample(jobs, sample))
            db.executemany("DELETE FROM mutation_specs WHERE job_id = ?", [(j,) for j in drop])
            db.executemany("DELETE FROM work_items WHERE job_id = ?", [(j,) for j in drop])
    return len(jobs)


def score_module(
    module: str, tests: tuple[str, ...], sample: int, seed: int, timeout: float
) -> ModuleScore:
    result = ModuleScore(module)
    with tempfile.TemporaryDirectory(prefix="fw1394-mutation-") as scratch:
        cfg, session = Path(scratch) / "cr.toml", Path(scratch) / "session.sqlite"
        cfg.write_text(config(module, tests, timeout))
        tool = [sys.executable, "-m", "cosmic_ray.cli"]
        subprocess.run([*tool, "init", str(cfg), str(session)], cwd=ROOT, check=True)
        keep_sample(session, sample, seed)
        subprocess.run([*tool, "exec", str(cfg), str(session)], cwd=ROOT, check=True)
        with sqlite3.connect(session) as db:
            rows = db.execute(
                "SELECT r.worker_outcome, r.test_outcome, r.diff, s.start_pos_row,"
                " s.operator_name FROM work_results r JOIN mutation_specs s USING (job_id)"
            ).fetchall()
    for worker, outcome, diff, line, operator in rows:
        worker, outcome = worker.lower(), outcome.lower()  # stored as enum names
        if worker != "normal" or outcome == "incompetent":
            result.incompetent += 1
        elif outcome == "survived":
            result.survived += 1
            result.survivors.append({"line": line, "operator": operator, "diff": diff})
        else:
            result.killed += 1
    return result


def report(scores: list[ModuleScore]) -> str:
    lines = []
    for entry in scores:
        shown = "-" if entry.score is None else f"{entry.score:6.1%}"
        lines.append(
            f"{entry.module:48} {shown:>7}  killed {entry.killed:4}  survived {entry.survived:4}"
            f"  not run {entry.incompetent}"
        )
        for survivor in entry.survivors:
            diff = "\n".join(
                "        " + d for d in str(survivor["diff"]).splitlines() if d[:1] in "+-"
            )
            lines.append(f"    line {survivor['line']} {survivor['operator']}\n{diff}")
    killed = sum(s.killed for s in scores)
    tried = killed + sum(s.survived for s in scores)
    total = f"{killed / tried:.1%}" if tried else "-"
    lines.append(f"total: {total} ({killed} of {tried} mutants killed)")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("modules", nargs="*", help="modules or packages (default: the plan)")
    parser.add_argument("--changed", metavar="REV", help="only library files changed since REV")
    parser.add_argument("--sample", type=int, default=0, help="mutants per module (0: all)")
    parser.add_argument("--seed", type=int, default=1394, help="seed of the sample")
    parser.add_argument("--timeout", type=float, default=120.0, help="seconds per mutant's run")
    parser.add_argument("--budget", type=float, default=0.0, help="stop after this many seconds")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    args = parser.parse_args(argv)
    if args.sample < 0 or args.timeout <= 0 or args.budget < 0:
        parser.error("--sample and --budget take numbers >= 0, --timeout > 0")
    if importlib.util.find_spec("cosmic_ray") is None:
        parser.error("needs cosmic-ray: pip install 'cosmic-ray>=8.3'")
    paths = changed_files(args.changed) if args.changed else args.modules or list(PLAN)
    modules = plan_for(paths)
    if not modules:
        print("mutation: no planned library module among " + (" ".join(paths) or "the change"))
        return 0
    started, scores = time.monotonic(), []
    for index, (module, tests) in enumerate(modules.items(), 1):
        if args.budget and time.monotonic() - started > args.budget:
            print(
                f"mutation: budget spent, {len(modules) - index + 1} modules left", file=sys.stderr
            )
            break
        print(f"[{index}/{len(modules)}] {module} against {' '.join(tests)}", file=sys.stderr)
        scores.append(score_module(module, tests, args.sample, args.seed, args.timeout))
    if args.json:
        print(json.dumps([{**vars(s), "score": s.score} for s in scores], indent=1))
    else:
        print(report(scores))
    return 0


if __name__ == "__main__":
    sys.exit(main())
