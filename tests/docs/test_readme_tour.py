"""The README's tour, run as it is written: its sh block, section by section.

The block's sections (separated by blank lines, each under a comment) do not
need each other, except that the trace section reads the trace the bus section
captured; so each section, or a section and the one it reads from, runs as a
test of its own, in a fresh directory holding only ``examples/`` (what a clone's
root has for it). The sections run side by side under pytest-xdist instead of
one after the other; run in order, the block is the same commands.

Each test runs in a network namespace of its own (``unshare -n``, loopback
only), so its bus "default" and its UDP ports meet no other test's. Every step
of the tour bounds its own duration; each test is bounded here too.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]

# A section whose comment starts with a key reads what the section before it
# wrote (the trace of the bus section), so the two run together.
READS_THE_SECTION_BEFORE = ("# Traces",)


def tour_script() -> str:
    readme = (ROOT / "README.md").read_text(encoding="utf-8")
    section = readme.split("## A short tour of the CLI", 1)[1]
    found = re.search(r"```sh\n(.*?)```", section, re.DOTALL)
    assert found is not None, "the README's tour has no sh block"
    return found.group(1)


def tour_parts() -> list[str]:
    """The block cut at its blank lines, a section glued to the one it reads from."""
    parts: list[str] = []
    for section in re.split(r"\n\s*\n", tour_script().strip()):
        if parts and section.startswith(READS_THE_SECTION_BEFORE):
            parts[-1] += "\n\n" + section
        else:
            parts.append(section)
    return parts


def title(part: str) -> str:
    """The first section's comment, as a test id: "Packets", "A virtual bus", ..."""
    heading = part.splitlines()[0].removeprefix("#").strip()
    return re.split(r"[:,(]", heading, maxsplit=1)[0].strip()


PARTS = tour_parts()


def test_the_parts_are_the_whole_block_in_order() -> None:
    assert "\n\n".join(PARTS) == re.sub(r"\n\s*\n", "\n\n", tour_script().strip())
    assert len(PARTS) >= 5, [title(part) for part in PARTS]
    assert all(part.startswith("#") for part in PARTS), "a section lacks its comment"


def run_part(part: str, where: Path) -> subprocess.CompletedProcess[str]:
    shutil.copytree(ROOT / "examples", where / "examples")
    (where / "tour.sh").write_text("set -eu\n" + part + "\n", encoding="utf-8")
    binaries = str(Path(sys.executable).parent)
    # The bus's sockets live here: a short path, as AF_UNIX addresses must be.
    with tempfile.TemporaryDirectory(prefix="tour-") as runtime:
        env = {
            **os.environ,
            "PATH": f"{binaries}:{os.environ['PATH']}",
            "XDG_RUNTIME_DIR": runtime,
        }
        command = ["unshare", "-n", "sh", "-c", "ip link set lo up && exec bash -x tour.sh"]
        # A hung step fails the test instead of stalling it.
        return subprocess.run(
            command, cwd=where, env=env, capture_output=True, text=True, timeout=300
        )


# What a part leaves behind, beyond running without an error, by a command in it.
def _decoded(out: str, where: Path) -> None:
    assert "read_quadlet_request" in out  # the first decode


def _captured_and_dissected(out: str, where: Path) -> None:
    assert (where / "trace.pcapng").stat().st_size > 0
    assert (where / "latency.png").read_bytes()[:4] == b"\x89PNG"
    assert (where / "fw1394.lua").read_text().startswith("-- fw1394.lua")


def _found(out: str, where: Path) -> None:
    assert (where / "fuzz-findings" / "report.json").exists()


CHECKS = {
    "fw1394 decode ": _decoded,
    "fw1394 dissect trace.pcapng --plot-latency latency.png": _captured_and_dissected,
    "fw1394 fuzz run udp:": _found,
}


def test_every_check_finds_its_command() -> None:
    for command in CHECKS:
        assert sum(command in part for part in PARTS) == 1, command


@pytest.mark.process
@pytest.mark.netns
@pytest.mark.slow
@pytest.mark.skipif(
    os.geteuid() != 0 or not shutil.which("unshare") or not shutil.which("ip"),
    reason="needs root, unshare and iproute2 for a network namespace of its own",
)
@pytest.mark.timeout(600)
@pytest.mark.parametrize("part", PARTS, ids=[title(part) for part in PARTS])
def test_a_part_of_the_tour_runs_as_written(tmp_path: Path, part: str) -> None:
    result = run_part(part, tmp_path)
    assert result.returncode == 0, result.stderr[-4000:]
    assert "Traceback" not in result.stdout + result.stderr
    for command, check in CHECKS.items():
        if command in part:
            check(result.stdout, tmp_path)
