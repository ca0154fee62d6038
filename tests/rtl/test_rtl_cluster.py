"""RTL campaigns on Dask distributed: a 2-worker LocalCluster against one worker.

The cluster runs one share of the seeds per worker (shrinking there too) and
the findings come back merged by signature; every planted defect one worker
finds in a campaign of the same length, the cluster finds.
"""

from __future__ import annotations

import json
from collections.abc import Iterator

import pytest

from fw1394.cli.main import main
from fw1394.fuzz import cluster, workers
from fw1394.fuzz.findings import Finding
from fw1394.fuzz.settings import Settings
from fw1394.rtl.simulation import missing_tools

distributed = pytest.importorskip("distributed", reason="Dask distributed is not installed")
pytestmark = [
    pytest.mark.rtl,
    pytest.mark.iverilog,
    pytest.mark.process,
    pytest.mark.skipif(missing_tools() is not None, reason=str(missing_tools())),
]
DEFECTS = ("no-second-grant", "no-closing-idle", "long-hold")


@pytest.fixture(scope="module")
def scheduler() -> Iterator[str]:
    with distributed.LocalCluster(
        n_workers=2,
        threads_per_worker=1,
        processes=True,
        host="127.0.0.1",
        dashboard_address=None,
    ) as local:
        yield local.scheduler_address


def test_the_cluster_finds_what_one_worker_finds(scheduler: str) -> None:
    settings = Settings("rtl:thesis", defects=DEFECTS, seed=4, max_cases=40, shrink_budget=2)
    alone = workers.run(settings, 1)
    spread = cluster.run(settings, scheduler)
    assert spread.cases == alone.cases == 40
    assert "2 workers" in " ".join(spread.notes)
    keys = {(f.oracle, f.signature) for f in spread.findings}
    assert len(keys) == len(spread.findings)  # merged: one finding per signature
    # The rule broken, and the kind of packet answered (closing-idle: any answer).
    planted = {
        ("interface", "no-grant:read"),
        ("interface", "hold:read"),
        ("interface", "closing-idle"),
    }

    def rules(findings: list[Finding]) -> set[tuple[str, str]]:
        return {
            (f.oracle, "closing-idle" if f.signature.startswith("closing-idle:") else f.signature)
            for f in findings
        }

    assert planted <= rules(alone.findings)
    assert planted <= rules(spread.findings)
    assert all(f.shrunk or f.reproduced is not None for f in spread.findings)


def test_fuzz_run_takes_a_cluster_address(
    scheduler: str, tmp_path: object, capsys: pytest.CaptureFixture[str]
) -> None:
    out = f"{tmp_path}/found"
    run = ["fuzz", "run", "rtl:thesis", "--defect", "no-second-grant", "--max-cases", "10"]
    status = main([*run, "--cluster", scheduler, "--findings", out, "--json", "--no-progress"])
    assert status == 1
    report = json.loads(capsys.readouterr().out)
    assert report["cases"] == 10
    assert ["interface", "no-grant:read"] in [
        [f["oracle"], f["signature"]] for f in report["findings"]
    ]


def test_an_unreachable_cluster_is_one_line(capsys: pytest.CaptureFixture[str]) -> None:
    run = ["fuzz", "run", "rtl:thesis", "--max-cases", "1", "--cluster", "tcp://127.0.0.1:9"]
    assert main(run) == 2
    err = capsys.readouterr().err
    assert "cluster tcp://127.0.0.1:9" in err and "Traceback" not in err
    # Refused at once, not after Dask's client timed out trying again.
    assert "refused" in err.lower() and "timed out" not in err.lower()
