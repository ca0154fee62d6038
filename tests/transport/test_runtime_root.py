"""The runtime root is this user's alone: nobody else can make it first, write in it
or list the bus names in it.

Without XDG_RUNTIME_DIR the root is ``<tmp>/fw1394-<uid>``; the temporary
directory is pointed at the test's own here. Another user is played by uid
12345 (the tests run as root, so they can chown to it and run ``ls`` as it).
"""

from __future__ import annotations

import os
import shutil
import stat
import subprocess
import tempfile
from pathlib import Path

import pytest

from fw1394.cli.main import main
from fw1394.transport.supervision.runtime import RuntimeRootError, prepare, runtime_root

OTHER_UID = 12345
needs_root = pytest.mark.skipif(os.getuid() != 0, reason="needs root to play another user")


@pytest.fixture
def tmp_root(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """Where the runtime root goes without XDG_RUNTIME_DIR (not made yet)."""
    monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    return tmp_path / f"fw1394-{os.getuid()}"


def mode_of(path: Path) -> int:
    return stat.S_IMODE(path.lstat().st_mode)


def test_the_root_is_made_private(tmp_root: Path) -> None:
    assert runtime_root() == tmp_root
    directory = prepare("private")
    assert directory == tmp_root / "private"
    assert mode_of(tmp_root) == 0o700 and tmp_root.lstat().st_uid == os.getuid()


def test_xdg_runtime_dir_is_used_when_set(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    base = tmp_path / "run-user"
    base.mkdir(mode=0o700)
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(base))
    assert prepare("x").parent == base / "fw1394"
    assert mode_of(base / "fw1394") == 0o700


def test_an_xdg_runtime_dir_that_is_not_there_is_an_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("XDG_RUNTIME_DIR", str(tmp_path / "missing"))
    with pytest.raises(RuntimeRootError, match="is not a directory"):
        runtime_root()


def test_an_old_root_of_this_user_readable_by_others_is_made_0700(tmp_root: Path) -> None:
    tmp_root.mkdir()
    tmp_root.chmod(0o755)
    runtime_root()
    assert mode_of(tmp_root) == 0o700


@needs_root
@pytest.mark.parametrize(
    ("shape", "message"),
    [
        ("other-owner", f"belongs to uid {OTHER_UID}, not this user"),
        ("world-writable", "has mode 0777: others can write in it"),
        ("group-writable", "has mode 0770: others can write in it"),
        ("symlink", "is not a directory"),
    ],
)
def test_a_root_someone_else_shaped_stops_bus_up_with_one_line(
    tmp_root: Path, shape: str, message: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if shape == "symlink":
        target = tmp_root.parent / "elsewhere"
        target.mkdir(mode=0o700)
        tmp_root.symlink_to(target)
    else:
        tmp_root.mkdir(mode=0o700)
        if shape == "other-owner":
            os.chown(tmp_root, OTHER_UID, OTHER_UID)
        else:
            tmp_root.chmod(0o777 if shape == "world-writable" else 0o770)
    assert main(["bus", "up", "--name", "shaped", "--nodes", "1", "--timeout", "5"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert str(tmp_root) in err and message in err
    assert not (tmp_root / "shaped").exists()  # nothing was started or written
    assert main(["bus", "status", "--name", "shaped", "--timeout", "0.1"]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.process
@needs_root
@pytest.mark.process
def test_another_user_cannot_list_the_bus_names(monkeypatch: pytest.MonkeyPatch) -> None:
    # A temporary directory others can reach, as /tmp is (pytest's own is 0700).
    shared = Path(tempfile.mkdtemp())
    try:
        shared.chmod(0o755)
        monkeypatch.delenv("XDG_RUNTIME_DIR", raising=False)
        monkeypatch.setattr(tempfile, "tempdir", str(shared))
        root = prepare("secret-bus-name").parent
        assert root.parent == shared
        listed = subprocess.run(
            ["ls", str(root)], user=OTHER_UID, capture_output=True, text=True, timeout=10
        )
        assert listed.returncode != 0 and "Permission denied" in listed.stderr
        assert "secret-bus-name" not in listed.stdout
        mine = subprocess.run(["ls", str(root)], capture_output=True, text=True, timeout=10)
        assert "secret-bus-name" in mine.stdout
    finally:
        shutil.rmtree(shared)
