"""Mutation score: plant small defects in the library, one at a time, and count the caught ones.

    python bench/mutation.py                          # every plan entry (hours)
    python bench/mutation.py --sample 30              # 30 mutants per plan entry, seeded
    python bench/mutation.py fw1394/transport/sansio/seal.py  # named modules, tests by plan
    python bench/mutation.py --changed HEAD~1 --budget 600   # what a change touched
    python bench/mutation.py --json                   # one JSON object for scripts

Each plan entry's files are mutated by cosmic-ray from one work database (operators:
comparisons, arithmetic, boolean and unary operators, numbers, break/continue,
exceptions, ...). Mutants inside an annotation of a module with ``from __future__
import annotations`` are set aside as equivalent (such annotations are never
evaluated); ``--sample`` draws that many of the others, reproducibly for a
``--seed``. Only the tests that matter run against a mutant:

* the plan's tests run once under coverage, each test in its own coverage context,
  which gives, for every line, the tests that execute it;
* a mutant inside a function body runs only the tests that executed its lines;
  one on code that runs on import (module and class bodies, defaults, decorators)
  runs all of the entry's planned tests; one on a line no planned test executes is a
  survivor without a run.

Tests run without the ones that start processes (``-m "not process"``: they take
minutes per mutant, and a child process would not see the mutant), each run in a
child forked from this process, which has the test libraries loaded and keeps
compiled bytecode (in a scratch ``sys.pycache_prefix``) for everything but the
mutated module. A mutant is *killed* when its tests fail or time out, *survived*
when they pass. Survivors are printed with their file, line and diff: each is a
missing test or an equivalent mutant, and ``docs/testing.md`` records the triage.
The score is killed / (killed + survived).

The files are mutated in place and restored after each mutant; the tests import
the library of the checkout this script is in. Run it in a checkout where nothing
else runs (a copy of the working tree will do).
"""

from __future__ import annotations

import argparse
import ast
import contextlib
import difflib
import importlib.util
import json
import os
import random
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from cosmic_ray.work_item import MutationSpec, WorkItem  # type: ignore[import-untyped]

ROOT = Path(__file__).resolve().parent.parent

#: Module or package (relative to the repository) -> the test directories that pin it.
PLAN: dict[str, tuple[str, ...]] = {
    "fw1394/crc": ("tests/crc", "tests/packets/test_packet_vectors.py"),
    "fw1394/packets": ("tests/packets", "tests/crc"),
    "fw1394/engine": ("tests/engine",),
    "fw1394/transport/sansio/seal.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_seal.py",
        "tests/transport/test_seal_edges.py",
    ),
    "fw1394/transport/sansio/wire.py": (
        "tests/transport/test_known_answer_frames.py",
        "tests/transport/test_bus_wire.py",
    ),
    "fw1394/transport/sansio/membership.py": (
        "tests/transport/test_bus_membership.py",
        "tests/transport/test_membership_pause.py",
        "tests/transport/test_membership_edges.py",
    ),
    "fw1394/transport/link.py": (
        "tests/transport/test_link.py",
        "tests/transport/test_link_edges.py",
        "tests/transport/test_link_mutants.py",
    ),
    "fw1394/boards": ("tests/boards", "tests/node/test_config_rom.py"),
    "fw1394/capture/formats": (
        "tests/capture/test_capture_formats.py",
        "tests/capture/test_capture_kernel.py",
        "tests/capture/test_capture_udp.py",
        "tests/capture/test_foreign_files.py",
        "tests/capture/test_robustness_captures.py",
        "tests/capture/test_pcapng_options_edges.py",
        "tests/capture/test_capture_formats_edges.py",
        "tests/capture/test_known_answer_trace.py",
        "tests/capture/test_live_capture_mutants.py",
        "tests/capture/test_capture_formats_mutants.py",
    ),
    "fw1394/fuzz/judge.py": (
        "tests/fuzz/test_fuzz_oracles.py",
        "tests/fuzz/test_fuzz_defects.py",
        "tests/fuzz/test_judge_edges.py",
    ),
}


@dataclass
class ModuleScore:
    module: str
    killed: int = 0
    survived: int = 0
    incompetent: int = 0  # the mutant could not even be imported or run
    mutants: int = 0  # all the entry's mutants, of which the sample was drawn
    annotations: int = 0  # of those, mutants of a never-evaluated annotation (equivalent)
    sampled: int = 0
    uncovered: int = 0  # survivors on a line no planned test executes (not run)
    timeouts: int = 0  # of the killed, those killed by running out of time
    selected_runs: int = 0  # mutants tested with only the tests that execute their line
    seconds: float = 0.0
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


#: How every test run starts: the in-process tiers only, stopping at the first failure.
PYTEST_ARGS = ("-x", "-q", "-p", "no:cacheprovider", "-m", "not process")


def command(tests: list[str] | tuple[str, ...]) -> str:
    return shlex.join([sys.executable, "-m", "pytest", *PYTEST_ARGS, *tests])


def config(modules: list[str], tests: tuple[str, ...], timeout: float) -> str:
    return (
        "[cosmic-ray]\n"
        f"module-path = {json.dumps(modules)}\n"
        f"timeout = {timeout}\n"
        "excluded-modules = []\n"
        f"test-command = {json.dumps(command(tests))}\n\n"
        '[cosmic-ray.distributor]\nname = "local"\n'
    )


Span = tuple[tuple[int, int], tuple[int, int]]


def _spans(nodes: list[ast.expr] | list[ast.stmt]) -> list[Span]:
    return [
        ((n.lineno, n.col_offset), (n.end_lineno or n.lineno, n.end_col_offset or 0)) for n in nodes
    ]


def annotation_spans(source: str) -> list[Span]:
    """Where the module's annotations are, if they are never evaluated (PEP 563)."""
    tree = ast.parse(source)
    lazy = any(
        isinstance(node, ast.ImportFrom)
        and node.module == "__future__"
        and any(alias.name == "annotations" for alias in node.names)
        for node in tree.body
    )
    if not lazy:
        return []
    found: list[ast.expr] = []
    for node in ast.walk(tree):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef) and node.returns:
            found.append(node.returns)
        elif isinstance(node, ast.arg | ast.AnnAssign) and node.annotation:
            found.append(node.annotation)
    return _spans(found)


def call_time_spans(source: str) -> list[Span]:
    """Statements that run only when their function is called, never on import."""
    found: list[ast.stmt] = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.FunctionDef | ast.AsyncFunctionDef):
            found.extend(node.body)
    return _spans(found)


def _inside(spec: MutationSpec, spans: list[Span]) -> bool:
    return any(lo <= tuple(spec.start_pos) and tuple(spec.end_pos) <= hi for lo, hi in spans)


# Runs the planned tests once under coverage, each test in its own coverage context,
# after importing the entry's modules so that import-time lines fall in the empty context;
# writes the node IDs of the tests that fail without any mutant beside the data file.
_COVER = """
import importlib, sys, coverage, pytest
data_file, files, modules, *args = sys.argv[1:]
cov = coverage.Coverage(data_file=data_file, include=files.split(","), branch=False)
failed, durations = set(), {}
class Contexts:
    @pytest.hookimpl(hookwrapper=True)
    def pytest_runtest_protocol(self, item, nextitem):
        cov.switch_context(item.nodeid)
        yield
        cov.switch_context("")
    def pytest_runtest_logreport(self, report):
        durations[report.nodeid] = durations.get(report.nodeid, 0.0) + report.duration
        if report.failed:
            failed.add(report.nodeid)
cov.start()
for name in modules.split(","):
    try:
        importlib.import_module(name)
    except Exception:
        pass
status = pytest.main(args, plugins=[Contexts()])
cov.stop()
cov.save()
open(data_file + ".failed", "w").write("".join(f"{n}\\n" for n in sorted(failed)))
open(data_file + ".durations", "w").write(repr(durations))
sys.exit(0 if status in (0, 1) else int(status))
"""


def tests_by_line(
    modules: list[str], tests: tuple[str, ...], scratch: Path
) -> tuple[dict[str, dict[int, set[str]]], list[str], dict[str, float]]:
    """Module -> line -> the planned tests (node IDs, "" for import time) that execute it;
    the planned tests that fail without any mutant (left out of every run); and the
    seconds each test function took under coverage."""
    data_file = scratch / "coverage"
    files = [str(ROOT / m) for m in modules]
    names = [m.removesuffix(".py").removesuffix("/__init__").replace("/", ".") for m in modules]
    # Not -x: a test that fails on its own (a flaky one, say) is left out, not fatal;
    # coverage slows tests down, so their timeout is longer here.
    args = [a for a in PYTEST_ARGS if a != "-x"] + ["-o", "timeout=900"]
    done = subprocess.run(
        [sys.executable, "-c", _COVER, str(data_file), ",".join(files), ",".join(names),
         *args, *tests],
        cwd=ROOT, capture_output=True, text=True, check=False,
    )  # fmt: skip
    if done.returncode != 0:
        tail = "\n".join(done.stdout.splitlines()[-15:])
        print(f"mutation: the planned tests cannot run:\n{tail}", file=sys.stderr)
        raise SystemExit(1)
    failing = Path(f"{data_file}.failed").read_text().split()
    if failing:
        print(f"mutation: left out, failing without mutants: {' '.join(failing)}", file=sys.stderr)
    import coverage

    data = coverage.CoverageData(basename=str(data_file))
    data.read()
    by_module: dict[str, dict[int, set[str]]] = {}
    for measured in data.measured_files():
        module = str(Path(measured).relative_to(ROOT))
        by_module[module] = {
            line: set(contexts) - set(failing)
            for line, contexts in data.contexts_by_lineno(measured).items()
        }
    seconds: dict[str, float] = {}
    for test, spent in ast.literal_eval(Path(f"{data_file}.durations").read_text()).items():
        seconds[_function(test)] = seconds.get(_function(test), 0.0) + spent
    return by_module, failing, seconds


def _function(node_id: str) -> str:
    """The test function of a node ID (parametrized cases run together)."""
    return re.sub(r"\[.*\]$", "", node_id)


def choose_tests(
    spec: MutationSpec, lines: dict[int, set[str]], call_time: list[Span]
) -> list[str] | None:
    """The tests that execute the mutated code; None when every planned test must run.

    Code that runs on import (module and class bodies, defaults, decorators) can change
    what any test sees, so it gets the whole plan; code in a function body gets the tests
    that executed its lines, whole functions (parametrized cases together).
    """
    if not _inside(spec, call_time):
        return None
    contexts: set[str] = set()
    for line in range(spec.start_pos[0], spec.end_pos[0] + 1):
        contexts |= lines.get(line, set())
    if "" in contexts:
        return None
    return sorted({_function(context) for context in contexts})


def enumerate_mutants(modules: list[str], tests: tuple[str, ...], scratch: Path) -> list[WorkItem]:
    """Every cosmic-ray mutant of ``modules``, in a stable order (the work IDs are random)."""
    from cosmic_ray.work_db import WorkDB, use_db  # type: ignore[import-untyped]

    cfg, work = scratch / "cr.toml", scratch / "work.sqlite"
    cfg.write_text(config(modules, tests, 1.0))
    subprocess.run([sys.executable, "-m", "cosmic_ray.cli", "init", str(cfg), str(work)],
                   cwd=ROOT, check=True)  # fmt: skip
    with use_db(str(work), WorkDB.Mode.open) as db:
        items = list(db.pending_work_items)
    return sorted(items, key=lambda item: [
        (str(m.module_path), m.start_pos, m.operator_name, m.occurrence) for m in item.mutations
    ])  # fmt: skip


#: Libraries the tests import, loaded once in this process so that each mutant's forked
#: test run starts without paying for them (fw1394 itself is never imported here).
PRELOAD = ("pytest", "hypothesis", "hypothesis.strategies", "construct", "crcmod", "numpy")


def run_forked(tests: list[str] | tuple[str, ...], timeout: float) -> str:
    """Run pytest on ``tests`` in a forked child: "survived", "killed" or "timeout"."""
    sys.stdout.flush()
    sys.stderr.flush()
    child = os.fork()
    if child == 0:  # pragma: no cover - the child
        status = 3
        try:
            os.setsid()  # its own group, so that a timeout stops what it started too
            quiet = os.open(os.devnull, os.O_WRONLY)
            os.dup2(quiet, 1)
            os.dup2(quiet, 2)
            import pytest

            # The run's own limit rules, not the suite's per-test timeout.
            limit = ["-o", f"timeout={int(timeout) + 1}"]
            status = int(pytest.main([*PYTEST_ARGS, *limit, *tests]))
        finally:
            os._exit(status)
    stop = time.monotonic() + timeout
    while True:
        done, status = os.waitpid(child, os.WNOHANG)
        if done:
            return "survived" if os.waitstatus_to_exitcode(status) == 0 else "killed"
        if time.monotonic() > stop:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(child, signal.SIGKILL)
            os.waitpid(child, 0)
            return "timeout"
        time.sleep(0.02)


def test_mutant(item: WorkItem, runs: list[tuple[list[str], float]]) -> tuple[str, str]:
    """Apply the mutant, run each (tests, time limit) until one fails; (outcome, diff).

    Bytecode is cached (under ``sys.pycache_prefix``) for speed, except the mutated
    module's: a mutant and its original can share a size and an mtime second.
    """
    from cosmic_ray.mutating import use_mutation  # type: ignore[import-untyped]
    from cosmic_ray.plugins import get_operator  # type: ignore[import-untyped]

    spec = item.mutations[0]
    operator = get_operator(spec.operator_name)(**spec.operator_args)
    compiled = Path(importlib.util.cache_from_source(str(ROOT / spec.module_path)))
    outcome = "survived"
    with contextlib.ExitStack() as stack:
        try:
            before, after = stack.enter_context(
                use_mutation(spec.module_path, operator, spec.occurrence)
            )
        except Exception as error:
            # Some operators trip over some parse trees (the exception-handler one does);
            # the file is only written once the mutant exists, so nothing needs undoing.
            where = f"{spec.module_path}:{spec.start_pos[0]}"
            print(f"mutation: cosmic-ray cannot apply the mutant at {where}: {error!r}",
                  file=sys.stderr)  # fmt: skip
            return "incompetent", ""
        if after is None:
            return "incompetent", ""
        for tests, limit in runs:
            compiled.unlink(missing_ok=True)
            outcome = run_forked(tests, limit)
            if outcome != "survived":
                break
    compiled.unlink(missing_ok=True)
    name = str(spec.module_path)
    diff = difflib.unified_diff(
        before.splitlines(keepends=True), after.splitlines(keepends=True), "a/" + name, "b/" + name
    )
    return outcome, "".join(diff)


def score_entry(
    entry: str,
    modules: list[str],
    tests: tuple[str, ...],
    sample: int,
    seed: int,
    timeout: float,
    deadline: float | None,
) -> ModuleScore:
    """Mutants of the plan entry's ``modules``, ``sample`` of them drawn across all its files."""
    result = ModuleScore(entry)
    started = time.monotonic()
    sources = {m: (ROOT / m).read_text() for m in modules}
    annotations = {m: annotation_spans(s) for m, s in sources.items()}
    call_time = {m: call_time_spans(s) for m, s in sources.items()}
    with tempfile.TemporaryDirectory(prefix="fw1394-mutation-") as scratch:
        items = enumerate_mutants(modules, tests, Path(scratch))
        result.mutants = len(items)
        items = [
            item for item in items
            if not _inside(item.mutations[0], annotations[str(item.mutations[0].module_path)])
        ]  # fmt: skip
        result.annotations = result.mutants - len(items)
        if 0 < sample < len(items):
            items = random.Random(seed).sample(items, sample)
        lines, failing, seconds = tests_by_line(modules, tests, Path(scratch))
    left_out = [f"--deselect={test}" for test in failing]
    everything = [*tests, *left_out]
    # A mutant's run may take twice what its tests took under coverage (itself
    # slower than a plain run), plus --timeout: on a loaded machine a fixed limit
    # would count slow tests as kills.
    whole = timeout + 2 * sum(seconds.values())
    for item in items:
        if deadline is not None and time.monotonic() > deadline:
            print(f"mutation: budget spent during {entry}", file=sys.stderr)
            break
        spec = item.mutations[0]
        module = str(spec.module_path)
        chosen = choose_tests(spec, lines.get(module, {}), call_time[module])
        result.sampled += 1
        runs: list[tuple[list[str], float]]
        if chosen == []:
            result.uncovered += 1  # no planned test executes the line: nothing to run
            runs = []
        elif chosen is None:
            runs = [(everything, whole)]
        else:
            result.selected_runs += 1
            limit = timeout + 2 * sum(seconds.get(test, 0.0) for test in chosen)
            runs = [([*chosen, *left_out], limit)]
        outcome, diff = test_mutant(item, runs)
        ran = "all planned tests" if chosen is None else f"{len(chosen)} tests"
        print(
            f"  {result.sampled}/{len(items)} {outcome:11} {module}:{spec.start_pos[0]}"
            f" {spec.operator_name} ({ran})",
            file=sys.stderr,
        )
        if outcome == "incompetent":
            result.incompetent += 1
        elif outcome == "survived":
            result.survived += 1
            result.survivors.append({
                "module": module, "line": spec.start_pos[0], "operator": spec.operator_name,
                "diff": diff, "tests_run": bool(runs),
            })  # fmt: skip
        else:
            result.killed += 1
            result.timeouts += outcome == "timeout"
    result.seconds = time.monotonic() - started
    return result


def report(scores: list[ModuleScore]) -> str:
    lines = []
    for entry in scores:
        shown = "-" if entry.score is None else f"{entry.score:6.1%}"
        lines.append(
            f"{entry.module:40} {shown:>7}  killed {entry.killed:4} ({entry.timeouts} by timeout)"
            f"  survived {entry.survived:4}"
            f" (no test runs the line: {entry.uncovered})  not run {entry.incompetent}"
            f"  | sampled {entry.sampled} of {entry.mutants - entry.annotations}"
            f" (+{entry.annotations} annotation mutants, equivalent)"
            f"  | {entry.selected_runs} on selected tests, {entry.seconds:.0f} s"
        )
        for survivor in entry.survivors:
            diff = "\n".join(
                "        " + d for d in str(survivor["diff"]).splitlines() if d[:1] in "+-"
            )
            where = f"{survivor['module']}:{survivor['line']}"
            untested = "" if survivor["tests_run"] else "  (no planned test runs it)"
            lines.append(f"    {where} {survivor['operator']}{untested}\n{diff}")
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
    parser.add_argument(
        "--timeout", type=float, default=120.0,
        help="seconds a mutant's run may take beyond twice its tests' time under coverage",
    )  # fmt: skip
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
    os.chdir(ROOT)  # cosmic-ray names the mutated files relative to the checkout
    sys.path.insert(0, str(ROOT))  # the tests import this checkout's library, not an install
    for library in PRELOAD:
        with contextlib.suppress(ImportError):
            importlib.import_module(library)
    deadline = time.monotonic() + args.budget if args.budget else None
    scores = []
    with tempfile.TemporaryDirectory(prefix="fw1394-mutation-pyc-") as bytecode:
        sys.pycache_prefix = bytecode  # the checkout's own __pycache__ never sees a mutant
        for index, (entry, (files, tests)) in enumerate(modules.items(), 1):
            if deadline is not None and time.monotonic() > deadline:
                left = len(modules) - index + 1
                print(f"mutation: budget spent, {left} plan entries left", file=sys.stderr)
                break
            print(f"[{index}/{len(modules)}] {entry} against {' '.join(tests)}", file=sys.stderr)
            scores.append(
                score_entry(entry, files, tests, args.sample, args.seed, args.timeout, deadline)
            )
    if args.json:
        print(json.dumps([{**vars(s), "score": s.score} for s in scores], indent=1))
    else:
        print(report(scores))
    return 0


if __name__ == "__main__":
    sys.exit(main())
