"""``fw1394 run`` and ``fw1394 libraw1394``: what a user sees, errors included."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.process

FW1394 = str(Path(sys.executable).with_name("fw1394"))


def fw1394(*args: str, env: dict[str, str]) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [FW1394, *args], env=env, capture_output=True, text=True, timeout=120, check=False
    )


@pytest.fixture
def env(tmp_path: Path) -> dict[str, str]:
    runtime = tmp_path / "run"
    runtime.mkdir()
    return {**os.environ, "XDG_RUNTIME_DIR": str(runtime), "XDG_CACHE_HOME": str(tmp_path)}


def one_line_error(result: subprocess.CompletedProcess[str], *words: str) -> None:
    assert result.returncode == 2
    assert result.stdout == ""
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in result.stderr
    for word in words:
        assert word in lines[0]


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_libraw1394_path_is_a_built_library_in_the_cache(env: dict[str, str]) -> None:
    result = fw1394("libraw1394", "--path", env=env)
    assert result.returncode == 0, result.stderr
    path = Path(result.stdout.strip())
    assert path.name == "libraw1394.so.11" and path.is_file()
    assert str(path).startswith(env["XDG_CACHE_HOME"])
    described = json.loads(fw1394("libraw1394", "--json", env=env).stdout)
    assert described["path"] == str(path)


def test_without_a_compiler_the_error_names_what_to_install(env: dict[str, str]) -> None:
    bare = {**env, "PATH": env["XDG_CACHE_HOME"], "CC": ""}
    result = subprocess.run(
        [sys.executable, "-m", "fw1394.cli.main", "libraw1394", "--path"],
        env=bare,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    one_line_error(result, "C compiler", "gcc")


@pytest.mark.skipif(shutil.which("gcc") is None, reason="gcc is not installed")
def test_run_refuses_a_bus_without_adapter_and_a_missing_program(env: dict[str, str]) -> None:
    one_line_error(fw1394("run", "--name", "nobus", "--", "true", env=env), "nobus", "bus up")
    one_line_error(fw1394("run", "--name", "nobus", env=env), "PROGRAM")
    missing = fw1394("run", "--name", "nobus", "--", "no-such-program-here", env=env)
    one_line_error(missing, "no-such-program-here")


def test_help_teaches_by_example(env: dict[str, str]) -> None:
    run_help = fw1394("run", "--help", env=env).stdout
    assert "fw1394 run --name rig -- testlibraw" in run_help
    assert "FW1394_BUS" in run_help
    assert "--path" in fw1394("libraw1394", "--help", env=env).stdout
