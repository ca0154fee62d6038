"""Mutation score: plant small defects in the library, one at a time, and count the caught ones.

    python bench/mutation.py                          # every plan entry (hours)
    python bench/mutation.py --sample 30              # 30 mutants per plan entry, seeded
    python bench/mutation.py fw1394/transport/sansio/seal.py  # named modules, tests by plan
    python bench/mutation.py --changed HEAD~1 --budget 600   # what a change touched
    python bench/mutation.py --json                   # one JSON object for scripts

Each plan entry's files are mutated by cosmic-ray from one work database (operators:
comparisons, arithmetic, boolean and unary operators, numbers, break/continue,
exceptions, ...), ``--sample`` draws that many mutants across all of them, and the
test directories that the plan below names for the entry run against every
mutant, without the tests that start processes (``-m "not process"``: they take
minutes per mutant, and a child started from a non-editable install would not
see the mutant). A mutant is *killed* when those tests
fail or time out, *survived* when they pass. Survivors are printed with their
file, line and diff: each is a missing test or an equivalent mutant, and
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
    "fw1394/transport/sansio/seal.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_seal.py",
    ),
    "fw1394/transport/sansio/wire.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_wire.py",
    ),
    "fw1394/transport/sansio/membership.py": (
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
    mutants: int = 0  # all the entry's mutants, of which the sample was drawn
    survivors: list[dict[str, object]] = field(default_factory=list)

    @property
    def score(self) -> float | None:
        tried = self.killed + self.survived
        return self.killed / tried if tried else None


def plan_for(paths: list[str]) -> dict[str, tuple[list[str], tuple[str, ...]]]:
    """Plan entry -> (its module files among ``paths``, the test directories that pin it)."""
    chosen: dict[str, tuple[list[str], tuple[str, ...]]] = {}
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
        modules = chosen.setdefault(entry, ([], PLAN[entry]))[0]
        for file in files:
            name = str(file.relative_to(ROOT))
            if file.suffix == ".py" and file.name != "__main__.py" and name not in modules:
                modules.append(name)
    return chosen


def changed_files(base: str) -> list[str]:
    done = subprocess.run(
        ["git", "diff", "--name-only", base, "--", "fw1394"],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        print(f"mutation: git cannot compare with {base!r}: {done.stderr.strip()}", file=sys.stderr)
        raise SystemExit(2)
    return [line for line in done.stdout.splitlines() if (ROOT / line).exists()]


def config(modules: list[str], tests: tuple[str, ...], timeout: float) -> str:
    command = f'{sys.executable} -m pytest -x -q -p no:cacheprovider -m "not process" ' + " ".join(
        tests
    )
    return (
        "[cosmic-ray]\n"
        f"module-path = {json.dumps(modules)}\n"
        f"timeout = {timeout}\n"
        "excluded-modules = []\n"
        f"test-command = {json.dumps(command)}\n\n"
        '[cosmic-ray.distributor]\nname = "local"\n'
    )


def keep_sample(work: Path, sample: int, seed: int) -> int:
    """Keep ``sample`` mutants of the work database, chosen with ``seed``; how many there were."""
    with sqlite3.connect(work) as db:
        jobs = [row[0] for row in db.execute("SELECT job_id FROM work_items ORDER BY job_id")]
        if 0 < sample < len(jobs):
            drop = set(jobs) - set(random.Random(seed).sample(jobs, sample))
            db.executemany("DELETE FROM mutation_specs WHERE job_id = ?", [(j,) for j in drop])
            db.executemany("DELETE FROM work_items WHERE job_id = ?", [(j,) for j in drop])
    return len(jobs)


def score_entry(
    entry: str, modules: list[str], tests: tuple[str, ...], sample: int, seed: int, timeout: float
) -> ModuleScore:
    """Mutants of the plan entry's ``modules``, ``sample`` of them drawn across all its files."""
    result = ModuleScore(entry)
    with tempfile.TemporaryDirectory(prefix="fw1394-mutation-") as scratch:
        cfg, work = Path(scratch) / "cr.toml", Path(scratch) / "work.sqlite"
        cfg.write_text(config(modules, tests, timeout))
        tool = [sys.executable, "-m", "cosmic_ray.cli"]
        subprocess.run([*tool, "init", str(cfg), str(work)], cwd=ROOT, check=True)
        result.mutants = keep_sample(work, sample, seed)
        subprocess.run([*tool, "exec", str(cfg), str(work)], cwd=ROOT, check=True)
        with sqlite3.connect(work) as db:
            rows = db.execute(
                "SELECT r.worker_outcome, r.test_outcome, r.diff, s.module_path,"
                " s.start_pos_row, s.operator_name"
                " FROM work_results r JOIN mutation_specs s USING (job_id)"
            ).fetchall()
    for worker, outcome, diff, path, line, operator in rows:
        worker, outcome = worker.lower(), outcome.lower()  # stored as enum names
        if worker != "normal" or outcome == "incompetent":
            result.incompetent += 1
        elif outcome == "survived":
            result.survived += 1
            result.survivors.append(
                {"module": path, "line": line, "operator": operator, "diff": diff}
            )
        else:
            result.killed += 1
    return result


def report(scores: list[ModuleScore]) -> str:
    lines = []
    for entry in scores:
        shown = "-" if entry.score is None else f"{entry.score:6.1%}"
        lines.append(
            f"{entry.module:48} {shown:>7}  killed {entry.killed:4}  survived {entry.survived:4}"
            f"  not run {entry.incompetent}  of {entry.mutants} mutants"
        )
        for survivor in entry.survivors:
            diff = "\n".join(
                "        " + d for d in str(survivor["diff"]).splitlines() if d[:1] in "+-"
            )
            where = f"{survivor['module']}:{survivor['line']}"
            lines.append(f"    {where} {survivor['operator']}\n{diff}")
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
    parser.add_argument("--sample", type=int, default=0, help="mutants per plan entry (0: all)")
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
    for index, (entry, (files, tests)) in enumerate(modules.items(), 1):
        if args.budget and time.monotonic() - started > args.budget:
            left = len(modules) - index + 1
            print(f"mutation: budget spent, {left} plan entries left", file=sys.stderr)
            break
        print(f"[{index}/{len(modules)}] {entry} against {' '.join(tests)}", file=sys.stderr)
        scores.append(score_entry(entry, files, tests, args.sample, args.seed, args.timeout))
    if args.json:
        print(json.dumps([{**vars(s), "score": s.score} for s in scores], indent=1))
    else:
        print(report(scores))
    return 0


if __name__ == "__main__":
    sys.exit(main())
