"""Runs as a whole: unreachable targets, findings directories kept or merged, workers."""

from __future__ import annotations

import json
import socket
from pathlib import Path

import pytest

from fw1394.cli.main import main
from fw1394.fuzz import workers
from fw1394.fuzz.campaign import run
from fw1394.fuzz.findings import load, merged
from fw1394.fuzz.restart import RestartRecord, ShellRestart, TargetUnreachable
from fw1394.fuzz.settings import Settings


def fuzz(*args: str) -> int:
    return main(["fuzz", *args])


def silent_port() -> int:
    """A loopback UDP port nothing listens on (bound, then let go)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


@pytest.mark.parametrize("framing", [(), ("--eth1394",)])
def test_a_target_that_never_answers_is_not_reachable(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], framing: tuple[str, ...]
) -> None:
    out = tmp_path / "found"
    status = fuzz(
        "run", f"udp:127.0.0.1:{silent_port()}", *framing, "--model", "memory",
        "--dead-after", "0.3", "--timeout", "0.1", "--findings", str(out),
    )  # fmt: skip
    err = capsys.readouterr().err.strip().splitlines()
    assert status == 2
    assert len(err) == 1 and "target not reachable" in err[0]
    assert not out.exists()


def test_a_silent_target_raises_unreachable_from_the_api() -> None:
    settings = Settings(f"udp:127.0.0.1:{silent_port()}", dead_after=0.2, timeout=0.1)
    with pytest.raises(TargetUnreachable):
        run(settings)


def test_an_unreachable_target_leaves_earlier_findings_alone(tmp_path: Path) -> None:
    out = tmp_path / "found"
    out.mkdir()
    (out / "001-kept.json").write_text("{}")
    status = fuzz(
        "run", f"udp:127.0.0.1:{silent_port()}", "--dead-after", "0.2", "--timeout", "0.1",
        "--findings", str(out), "--force",
    )  # fmt: skip
    assert status == 2
    assert [p.name for p in out.iterdir()] == ["001-kept.json"]


def run_into(out: Path, defect: str, *extra: str) -> int:
    return fuzz(
        "run", "inproc:memory", "--defect", defect, "--max-cases", "300",
        "--shrink-budget", "20", "--findings", str(out), "--no-progress", *extra,
    )  # fmt: skip


def signatures(out: Path) -> set[tuple[str, str]]:
    return {finding.key for _, finding in load(out)}


def test_findings_are_never_overwritten_without_force(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "found"
    assert run_into(out, "answers-other-node") == 1
    first = {p.name: p.read_text() for p in out.iterdir()}
    capsys.readouterr()
    assert run_into(out, "bad-crc-read-answered") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--force" in err[0]
    assert {p.name: p.read_text() for p in out.iterdir()} == first
    assert fuzz("run", "inproc:memory", "--max-cases", "50", "--findings", str(out), "--force") == 0
    assert signatures(out) == set()


def test_runs_merge_by_signature(tmp_path: Path) -> None:
    one, two, both = tmp_path / "one", tmp_path / "two", tmp_path / "both"
    assert run_into(one, "answers-other-node") == 1
    assert run_into(two, "bad-crc-read-answered") == 1
    assert run_into(both, "answers-other-node") == 1
    assert run_into(both, "bad-crc-read-answered", "--merge") == 1
    assert signatures(both) == signatures(one) | signatures(two)
    assert signatures(one) - signatures(two) and signatures(two) - signatures(one)
    # A signature found again keeps its first reproducer.
    again = {f.key: f for _, f in load(one)}
    assert run_into(both, "answers-other-node", "--merge") == 1
    kept = {f.key: f for _, f in load(both)}
    assert all(kept[key].stream == again[key].stream for key in again)
    # The merge of two lists is one finding per signature.
    firsts = [f for _, f in load(one)]
    assert merged(firsts, firsts) == firsts


@pytest.mark.process
def test_workers_repeat_a_run_and_merge_their_findings() -> None:
    settings = Settings(
        "inproc:memory",
        defects=("answers-other-node", "bad-crc-read-answered", "crash-on-empty-block-write"),
        max_cases=900,
        shrink_budget=20,
        seed=5,
    )
    first = workers.run(settings, 2)
    second = workers.run(settings, 2)
    assert first.cases == second.cases == 900
    texts = [[json.dumps(f.to_json(), sort_keys=True) for f in r.findings] for r in (first, second)]
    assert texts[0] == texts[1] and texts[0]
    # One finding per signature, each from the worker that found it, whose seed it keeps.
    keys = [f.key for f in first.findings]
    assert len(keys) == len(set(keys))
    seeds = {f.settings["seed"] for f in first.findings}
    assert seeds <= {workers.worker_seed(5, 0), workers.worker_seed(5, 1)}
    # Each worker is an ordinary campaign: the same findings as running it alone.
    alone = run(workers.worker_settings(settings, 1, 2))
    from_worker_1 = {f.key for f in first.findings if f.settings["seed"] == alone.settings.seed}
    assert from_worker_1 <= {f.key for f in alone.findings}


def test_worker_seeds_and_shares() -> None:
    settings = Settings("inproc:memory", max_cases=7, seed=3)
    shares = [workers.worker_settings(settings, w, 3) for w in range(3)]
    assert [s.max_cases for s in shares] == [3, 2, 2]
    assert shares[0].seed == 3 and len({s.seed for s in shares}) == 3
    remote = Settings("udp:127.0.0.1:1140{worker}")
    assert workers.worker_settings(remote, 2, 3).target == "udp:127.0.0.1:11402"


def test_a_remote_target_needs_one_node_per_worker(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    findings = str(tmp_path / "findings")
    assert fuzz("run", "udp:127.0.0.1:9", "--jobs", "2", "--findings", findings) == 2
    assert "{worker}" in capsys.readouterr().err


@pytest.mark.process
def test_a_shell_restart_keeps_status_and_output() -> None:
    record = ShellRestart("echo worker $FW1394_FUZZ_WORKER {worker}; exit 4", worker=3)()
    assert record == RestartRecord("echo worker $FW1394_FUZZ_WORKER 3; exit 4", 4, "worker 3 3\n")
    # A node left running in the background does not hold the restart up.
    quick = ShellRestart("sleep 5 & echo up", timeout=2.0)()
    assert quick.status == 0 and quick.output == "up\n"
