"""``fw1394 fuzz``: runs, reproducers, replays, shrinking, errors."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from fw1394.cli.main import main
from fw1394.fuzz.campaign import replayer, run
from fw1394.fuzz.findings import load
from fw1394.fuzz.settings import Settings
from fw1394.fuzz.shrink import shrink
from fw1394.fuzz.targets import open_target


def fuzz(*args: str) -> int:
    return main(["fuzz", *args])


def test_run_saves_reproducers_that_replay(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "found"
    status = fuzz(
        "run", "inproc:memory", "--defect", "answers-other-node",
        "--max-cases", "300", "--findings", str(out), "--no-progress",
    )  # fmt: skip
    assert status == 1
    text = capsys.readouterr().out
    assert "silence" in text and "other-node" in text and "coverage:" in text
    report = json.loads((out / "report.json").read_text())
    assert report["cases"] == 300 and report["findings"]
    assert set(report["coverage"]["oracles"]) == {
        "silence",
        "reply",
        "liveness",
        "state",
        "process",
        "interface",
        "side-effect",
    }
    loaded = load(out)
    assert loaded and all(f.reproduced and f.shrunk for _, f in loaded)
    assert fuzz("replay", str(out)) == 1
    assert "REPRODUCED" in capsys.readouterr().out
    # The same findings on a node without the defect: fixed.
    for path, finding in loaded:
        data = finding.to_json()
        data["settings"]["defects"] = []
        path.write_text(json.dumps(data))
    assert fuzz("replay", str(out), "--json") == 0
    lines = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert lines and not any(line["reproduced"] for line in lines)


def test_a_seed_repeats_a_run() -> None:
    def once() -> dict[str, object]:
        settings = Settings(
            "inproc:snake2010", defects=("stale-read",), max_cases=800, seed=5, shrink_budget=20
        )
        report = run(settings)
        data = report.to_json()
        for volatile in ("elapsed", "rate"):
            del data[volatile]
        timeline = data["timeline"]
        assert isinstance(timeline, list)
        data["timeline"] = [{k: v for k, v in p.items() if k != "seconds"} for p in timeline]
        return data

    assert once() == once()


def test_shrinking_leaves_the_packet_that_matters() -> None:
    settings = Settings("inproc:memory", defects=("wedge-after-long-block-write",), max_cases=400)
    report = run(settings)
    wedge = next(f for f in report.findings if f.oracle == "liveness")
    assert wedge.shrunk and wedge.reproduced
    cases = [e for e in wedge.stream if e.role == "case"]
    # A block write header claiming more than 2048 bytes is all it takes.
    assert len(cases) == 1 and len(cases[0].raw) <= 24
    assert cases[0].raw[12:14] == (2049).to_bytes(2, "big") or len(cases[0].raw) > 16
    assert len(wedge.stream) <= 3
    # An unshrunk copy shrinks to the same stream again.
    again = shrink(wedge, replayer(settings, open_target(settings)), 100)
    assert again.stream == wedge.stream


def test_a_corpus_seeds_the_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    corpus = tmp_path / "seeds.txt"
    corpus.write_text(
        "# two packets\n"
        "ffc0f140 ffc1ffff f0000984 5bdd119c\n"
        "ffc00100 ffc10000 00000010 00000005 00000000\n"
    )
    status = fuzz(
        "run", "inproc:memory", "--corpus", str(corpus), "--max-cases", "200",
        "--findings", str(tmp_path / "f"), "--json",
    )  # fmt: skip
    assert status in (0, 1)
    report = json.loads(capsys.readouterr().out)
    assert report["coverage"]["labels"].get("corpus-mutation", 0) > 0


def test_the_hypothesis_engine_shrinks_its_findings(
    findings_dir: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    status = fuzz(
        "run", "inproc:memory", "--engine", "hypothesis", "--defect", "stale-tlabel",
        "--max-cases", "60", "--findings", str(findings_dir), "--seed", "1",
    )  # fmt: skip
    assert status == 1
    assert "read:tlabel" in capsys.readouterr().out
    assert all(f.shrunk for _, f in load(findings_dir))


def test_defects_are_listed(capsys: pytest.CaptureFixture[str]) -> None:
    assert fuzz("defects", "qla1") == 0
    text = capsys.readouterr().out
    assert "wedge-after-long-block-write" in text and "hw-version-swapped" in text
    assert "stale-read" not in text


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["run", "serial:/dev/ttyS0"], "use inproc:BOARD"),
        (["run", "inproc:toaster"], "unknown board kind"),
        (["run", "inproc:qla1", "--defect", "nonsense"], "unknown defect"),
        (["run", "bus:x/0", "--defect", "stale-tlabel"], "in-process"),
        (["run", "inproc:memory", "--max-cases", "-1"], "max-cases"),
        (["run", "inproc:memory", "--probe-every", "0"], "probe-every"),
        (["run", "inproc:memory", "--corpus", "/nonexistent/seeds"], "nonexistent"),
        (["run", "inproc:memory", "--engine", "hypothesis"], "--max-cases or --duration"),
        (["run", "udp:127.0.0.1:99999"], "udp:HOST[:PORT]"),
        (["run", "bus:default/99", "--max-cases", "1"], "NODE a physical ID"),
        (["replay", "/nonexistent/findings"], "nonexistent"),
        (["defects", "toaster"], "unknown board kind"),
        (["serve", "memory", "--listen", "10.1.2.3:5000"], "only loopback"),
        (["serve", "memory", "--listen", "nowhere"], "HOST:PORT"),
    ],
)
def test_bad_input_is_one_line(
    args: list[str], message: str, capsys: pytest.CaptureFixture[str], findings_dir: Path
) -> None:
    if args[0] == "run":
        args = [*args, "--findings", str(findings_dir)]
    assert fuzz(*args) == 2
    err = capsys.readouterr().err
    assert message in err and len(err.strip().splitlines()) == 1


@pytest.mark.parametrize(
    "settings", [[], {"target": 5}, {"target": "inproc:memory", "seed": "x"}, {"contract": "?"}]
)
def test_a_finding_file_that_is_not_one(
    findings_dir: Path, capsys: pytest.CaptureFixture[str], settings: object
) -> None:
    (findings_dir / "001-x.json").write_text("[1, 2]")
    assert fuzz("replay", str(findings_dir)) == 2
    assert "001-x.json" in capsys.readouterr().err
    broken: dict[str, object] = {"format": "fw1394-fuzz-finding/1", "oracle": "reply"}
    broken["signature"] = "s"
    broken |= {"target": "inproc:memory", "settings": settings, "expected": "", "observed": ""}
    broken |= {"case": 1, "label": "", "reproduced": None, "shrunk": False, "stream": []}
    (findings_dir / "001-x.json").write_text(json.dumps(broken))
    assert fuzz("replay", str(findings_dir)) == 2
    assert len(capsys.readouterr().err.strip().splitlines()) == 1


def test_a_forced_run_replaces_the_old_findings(findings_dir: Path) -> None:
    (findings_dir / "007-old-finding.json").write_text("{}")
    (findings_dir / "notes.txt").write_text("mine")
    run = ("run", "inproc:memory", "--max-cases", "50", "--findings", str(findings_dir))
    assert fuzz(*run, "--force") == 0
    assert sorted(p.name for p in findings_dir.iterdir()) == ["notes.txt", "report.json"]


def test_plot_draws_the_run_and_refuses_a_format_it_cannot_write(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    pytest.importorskip("matplotlib")
    picture = tmp_path / "run.png"
    status = fuzz(
        "run", "inproc:memory", "--defect", "answers-other-node", "--max-cases", "2000",
        "--findings", str(tmp_path / "found"), "--no-progress", "--plot", str(picture), "--json",
    )  # fmt: skip
    assert status == 1
    report = json.loads(capsys.readouterr().out)
    # A PNG (its signature, from the PNG specification), and a timeline that grows.
    assert picture.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    timeline = report["timeline"]
    assert timeline[0]["cases"] == 0 and timeline[-1]["cases"] == 2000
    assert [p["cases"] for p in timeline] == sorted(p["cases"] for p in timeline)
    assert timeline[-1]["findings"] == len(report["findings"])
    assert timeline[-1]["bins_hit"] == len(report["coverage"]["bins"])
    for bad in (["--plot", str(tmp_path / "run.txt")], ["--plot", "x.png", "--jobs", "2"]):
        status = fuzz("run", "inproc:memory", "--max-cases", "10", *bad)
        err = capsys.readouterr().err.strip().splitlines()
        assert status == 2 and len(err) == 1 and "Traceback" not in err[0]
    assert not (tmp_path / "run.txt").exists()
