"""A findings directory kept true while the campaign runs, and a run that keeps to --duration.

Each campaign here is a real ``fw1394 fuzz run`` process: killed with SIGKILL
mid-campaign it must leave every finding seen so far as a whole file, stopped
by ``timeout`` (SIGTERM) it must end at once with its findings saved, and
with ``--duration`` its shrinking must end inside the duration too, showing
its progress. The findings are checked against the 1394 header layout written
out here (destination_ID in bits 31-16 of quadlet 0, tcode in bits 7-4).
"""

from __future__ import annotations

import contextlib
import json
import os
import signal
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

from fw1394.fuzz.findings import load

pytestmark = [pytest.mark.process]

#: Seconds a campaign process may take to start and find its first findings (its
#: imports alone take a while on a loaded machine).
STARTUP_S = 150
#: Planted defects, each found within the first few hundred cases.
DEFECTS = ("answers-other-node", "stale-tlabel", "broadcast-read-answered")


#: The independent Eth1394 node with four planted violations (see test_fuzz_restart.py).
NODE = Path(__file__).with_name("eth1394_node.py")
NODE_ARGS = "120 --wedge --other-nodes --bad-crc-reads --side-effect"


def free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        port: int = probe.getsockname()[1]
        return port


def restart_script(directory: Path, port: int) -> Path:
    """Stops the node it started last (waits until it is gone), starts a fresh one."""
    pidfile = directory / "node.pid"
    script = directory / "restart-node.sh"
    script.write_text(
        "#!/bin/sh\n"
        f'if [ -f "{pidfile}" ]; then\n'
        f'  old=$(cat "{pidfile}"); kill "$old" 2>/dev/null\n'
        '  while [ "$(cut -d" " -f3 /proc/$old/stat 2>/dev/null || echo Z)" != Z ]; do\n'
        "    sleep 0.01\n"
        "  done\n"
        "fi\n"
        f'"{sys.executable}" "{NODE}" {port} {NODE_ARGS} >/dev/null &\n'
        f'echo $! > "{pidfile}"\n'
    )
    script.chmod(0o755)
    return script


def command(*args: str) -> list[str]:
    return [sys.executable, "-m", "fw1394.cli.main", "fuzz", "run", *args]


def inproc_campaign(found: Path, *extra: str) -> list[str]:
    defects = [part for name in DEFECTS for part in ("--defect", name)]
    return command("inproc:memory", *defects, "--duration", "120", "--findings", str(found), *extra)


def wait_for(condition: object, seconds: float) -> None:
    limit = time.monotonic() + seconds
    while not condition():  # type: ignore[operator]
        assert time.monotonic() < limit, "gave up waiting"
        time.sleep(0.05)


def reproducers(found: Path) -> list[Path]:
    return sorted(found.glob("[0-9][0-9][0-9]-*.json"))


def destination_node(packet: bytes) -> int:
    """The 6-bit node number of a request's destination_ID (quadlet 0, bits 31-16)."""
    return int.from_bytes(packet[:4], "big") >> 16 & 0x3F


@pytest.mark.timeout(300)
@pytest.mark.parametrize("jobs", [1, 2])
def test_a_campaign_killed_mid_run_keeps_every_finding_so_far(tmp_path: Path, jobs: int) -> None:
    found = tmp_path / "found"
    process = subprocess.Popen(
        inproc_campaign(found, "--no-progress", "--jobs", str(jobs)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )
    workers: list[int] = []
    try:
        wait_for(lambda: len(reproducers(found)) >= 3 or process.poll() is not None, STARTUP_S)
        time.sleep(0.5)  # and a little more fuzzing
        assert process.poll() is None, process.stderr.read() if process.stderr else ""
        workers = [int(pid) for pid in children(process.pid)]
        process.kill()  # SIGKILL: nothing runs after this
    finally:
        process.kill()
        process.wait(30)
    # Workers left behind end by themselves (the kernel tells them their parent died).
    wait_for(lambda: not any(alive(pid) for pid in workers), 60)
    files = reproducers(found)
    # SIGKILL may land between a finding's write and its rename: that leaves at
    # most one hidden file per killed process (the loader below must skip it).
    leftovers = list(found.glob(".*.tmp"))
    assert len(leftovers) <= 1 + len(workers), leftovers
    # Every file is a whole finding.
    loaded = load(found)
    assert [path for path, _ in loaded] == files and len(files) >= 3
    keys = {(f.oracle, f.signature) for _, f in loaded}
    if jobs == 1:  # the report names the files' findings (workers hand on findings only)
        report = json.loads((found / "report.json").read_text())
        assert report["stopped"] == "running"
        assert report["cases"] > 0
        assert {(f["oracle"], f["signature"]) for f in report["findings"]} <= keys
    # The node (0xffc0) answered a read for another node: that finding's packet says so.
    other = [f for _, f in loaded if f.signature.startswith("other-node:read")]
    assert other and destination_node(other[0].packet) not in (0, 63)
    # Kept as found: the killed run never got to shrink.
    assert all(not f.shrunk for _, f in loaded)


def alive(pid: int) -> bool:
    """``pid`` runs (a zombie waiting for its reaper counts as gone)."""
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except (OSError, IndexError):
        return False
    return state != "Z"


@pytest.mark.timeout(300)
def test_sigterm_stops_a_campaign_at_once_with_its_findings_saved(tmp_path: Path) -> None:
    """What ``timeout 150 fw1394 fuzz run ...`` sends: the run ends now, findings as found."""
    found = tmp_path / "found"
    process = subprocess.Popen(
        inproc_campaign(found, "--json", "--no-progress"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        wait_for(lambda: len(reproducers(found)) >= 3 or process.poll() is not None, STARTUP_S)
        assert process.poll() is None
        process.send_signal(signal.SIGTERM)
        out, err = process.communicate(timeout=60)  # not the 120 s of --duration
    finally:
        process.kill()
        process.wait(30)
    assert process.returncode == 1, err  # findings, as a finished run with findings
    assert "Traceback" not in err
    printed = json.loads(out)
    saved = json.loads((found / "report.json").read_text())
    assert printed["stopped"] == saved["stopped"] == "terminated (SIGTERM)"
    assert any("terminated" in note for note in saved["notes"])
    loaded = load(found)
    assert len(loaded) == len(saved["findings"]) >= 3
    assert all(not f.shrunk for _, f in loaded)


def children(pid: int) -> list[str]:
    try:
        return Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    except OSError:
        return []


#: Seconds a campaign may take to end after SIGTERM (its --duration is 120 s).
PROMPT_S = 30
#: One campaign per delay after the moment: SIGTERM broke a campaign at some moments
#: a few milliseconds long, and not in every run.
DELAYS_S = (0.0, 0.01, 0.03, 0.06)


def terminated_campaign(
    found: Path, moment: str, delay: float, sender: str
) -> tuple[int, str, str, list[int]]:
    """A --jobs 2 campaign sent SIGTERM ``delay`` seconds after ``moment``: its exit
    status, stdout, stderr and workers."""
    process = subprocess.Popen(
        inproc_campaign(found, "--json", "--jobs", "2"),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # a process group of its own, as under timeout(1)
    )

    def ready() -> bool:
        if moment == "worker-forked":
            return len(children(process.pid)) >= 1
        if moment == "workers-forked":
            return len(children(process.pid)) >= 2
        return len(reproducers(found)) >= 1

    workers: list[int] = []
    try:
        # Looked at every millisecond: the moments that broke a campaign last about that.
        limit = time.monotonic() + STARTUP_S
        while not ready() and process.poll() is None:
            assert time.monotonic() < limit, "gave up waiting"
            time.sleep(0.001)
        time.sleep(delay)
        assert process.poll() is None
        workers = [int(pid) for pid in children(process.pid)]
        if sender == "campaign":
            process.send_signal(signal.SIGTERM)
        else:
            os.killpg(process.pid, signal.SIGTERM)
        out, err = process.communicate(timeout=PROMPT_S)
    finally:
        process.kill()
        process.wait(30)
        for pid in workers:  # (gone already unless the test failed)
            with contextlib.suppress(ProcessLookupError):
                os.kill(pid, signal.SIGKILL)
    return process.returncode, out, err, workers


@pytest.mark.timeout(300)
@pytest.mark.parametrize("sender", ["campaign", "process-group"])
@pytest.mark.parametrize("moment", ["worker-forked", "workers-forked", "first-finding"])
def test_sigterm_stops_every_worker_and_keeps_their_findings(
    tmp_path: Path, moment: str, sender: str
) -> None:
    """With --jobs the workers are other processes, starting while the campaign's
    process starts its pool. SIGTERM reaches the campaign's process alone (``kill``),
    or every process of the group (``timeout``, a terminal); either way, as soon as the
    first worker is forked, or all, or a finding is written, the run ends at once with
    a report, and the findings on disk are whole and the report's."""
    for delay in DELAYS_S:
        found = tmp_path / f"found-{delay}"
        status, out, err, workers = terminated_campaign(found, moment, delay, sender)
        assert "Traceback" not in err and "Exception" not in err, err
        report = json.loads(out)
        assert report["stopped"] == "terminated (SIGTERM)"
        saved = json.loads((found / "report.json").read_text())
        assert saved["stopped"] == "terminated (SIGTERM)"
        # Exit status 1 with findings, as a finished run with findings.
        assert status == (1 if report["findings"] else 0), err
        # Every file is a whole finding, and the report names exactly those.
        on_disk = {(f.oracle, f.signature) for _, f in load(found)}
        assert len(on_disk) == len(reproducers(found))
        assert on_disk == {(f["oracle"], f["signature"]) for f in report["findings"]}
        if moment == "first-finding":
            assert on_disk
        assert not any(alive(pid) for pid in workers)


@pytest.mark.slow
@pytest.mark.timeout(300)
def test_shrinking_stays_inside_the_duration_and_shows_progress(tmp_path: Path) -> None:
    """A remote node restarted before every replay: shrinking its four findings with 300
    replays each would take minutes, the whole run must still end by --duration."""
    port = free_port()
    script = restart_script(tmp_path, port)
    subprocess.run([str(script)], check=True, stdout=subprocess.DEVNULL)
    found = tmp_path / "found"
    duration = 20
    try:
        started = time.monotonic()
        campaign = command(
            f"udp:127.0.0.1:{port}", "--eth1394", "--model", "memory",
            "--restart", str(script), "--duration", str(duration),
            "--shrink-budget", "300", "--state-every", "16", "--timeout", "0.2",
            "--dead-after", "10", "--findings", str(found), "--json", "--progress",
        )  # fmt: skip
        result = subprocess.run(campaign, capture_output=True, text=True, timeout=280, check=False)
        took = time.monotonic() - started
    finally:
        with contextlib.suppress(ProcessLookupError, FileNotFoundError, ValueError):
            os.kill(int((tmp_path / "node.pid").read_text()), signal.SIGTERM)
    assert result.returncode == 1, result.stderr
    report = json.loads(result.stdout)
    # Inside the duration, but for one replay (a node restart, which waits for the new
    # process to answer) begun before the end, and the interpreter's start: generous
    # for a loaded machine. Unbounded, shrinking these findings takes minutes.
    assert report["elapsed"] < duration + 10, report["elapsed"]
    assert took < duration + 30, f"{took:.1f} s for --duration {duration}"
    assert report["findings"]
    # Some of it shrunk, and the rest said to be as found.
    assert any(f["shrunk"] for f in report["findings"]) or any(
        "--duration reached while shrinking" in note for note in report["notes"]
    )
    # The progress on stderr (a pipe here: plain lines) names both phases.
    assert "fuzzing: " in result.stderr
    assert "shrinking " in result.stderr and " replays)" in result.stderr
    assert "Traceback" not in result.stderr
