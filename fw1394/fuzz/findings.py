"""Findings: one reproducer per distinct violation, kept as JSON files in a directory.

A finding names the oracle and the signature it is deduplicated by, the
packet that showed it (hex), the expected and observed replies, and the
stream of packets that led there (roles, times and bytes), shrunk when
possible. ``fw1394 fuzz replay DIR`` sends the streams again.
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Sequence
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from fw1394.errors import UsageError
from fw1394.fuzz.trial import Entry

FORMAT = "fw1394-fuzz-finding/1"
_PATTERN = "[0-9][0-9][0-9]-*.json"


@dataclass
class Finding:
    """A violation worth a reproducer."""

    oracle: str
    signature: str
    #: The target as given on the command line, and the options it was built with.
    target: str
    settings: dict[str, Any]
    expected: str
    observed: str
    #: The case (1-based) that showed it, and the label of how that case was made.
    case: int
    label: str
    #: The packets that lead to the violation, the last case among them being the
    #: one that shows it.
    stream: list[Entry] = field(default_factory=list)
    #: After shrinking: the stream reproduces the violation on a fresh node.
    reproduced: bool | None = None
    shrunk: bool = False
    #: Restarts of the node this violation led to: command, exit status, output.
    restarts: list[dict[str, Any]] = field(default_factory=list)

    @property
    def key(self) -> tuple[str, str]:
        return (self.oracle, self.signature)

    @property
    def packet(self) -> bytes:
        """The last case packet of the stream (the minimal packet once shrunk)."""
        cases = [entry.raw for entry in self.stream if entry.role == "case"]
        return cases[-1] if cases else b""

    def to_json(self) -> dict[str, Any]:
        data = asdict(self)
        data["format"] = FORMAT
        data["packet"] = self.packet.hex()
        data["stream"] = [
            {"role": e.role, "time": e.time, "raw": e.raw.hex(), "label": e.label}
            for e in self.stream
        ]
        return data

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> Finding:
        if data.get("format") != FORMAT:
            raise ValueError(f"not a finding (format {data.get('format')!r}, wanted {FORMAT})")
        stream = [
            Entry(str(e["role"]), float(e["time"]), bytes.fromhex(e["raw"]), str(e["label"]))
            for e in data["stream"]
        ]
        names = {
            "oracle",
            "signature",
            "target",
            "settings",
            "expected",
            "observed",
            "case",
            "label",
            "reproduced",
            "shrunk",
        }
        restarts = [dict(r) for r in data.get("restarts", [])]
        return cls(**{k: data[k] for k in names}, stream=stream, restarts=restarts)


def file_name(index: int, finding: Finding) -> str:
    slug = re.sub(r"[^a-z0-9]+", "-", f"{finding.oracle}-{finding.signature}".lower())
    return f"{index:03d}-{slug.strip('-')[:80]}.json"


class FindingsExist(UsageError):
    """A findings directory already holds findings and was not to be replaced."""


def holds_findings(directory: Path) -> bool:
    """``directory`` holds reproducers, or the report of an earlier run that found
    something. The report of a run that found nothing is no finding to protect."""
    if not directory.is_dir():
        return False
    if any(directory.glob(_PATTERN)):
        return True
    report = directory / "report.json"
    if not report.exists():
        return False
    try:
        found = json.loads(report.read_text(encoding="utf-8")).get("findings")
    except (OSError, ValueError, AttributeError):
        return True  # a report that cannot be read is kept, not overwritten
    return bool(found)


def merged(*runs: list[Finding]) -> list[Finding]:
    """The findings of several runs, one per (oracle, signature): the first one seen
    (a shrunk one before one that is not)."""
    kept: dict[tuple[str, str], Finding] = {}
    for findings in runs:
        for finding in findings:
            old = kept.get(finding.key)
            if old is None or (finding.shrunk and not old.shrunk):
                kept[finding.key] = finding
    return list(kept.values())


def prepare(directory: Path, *, force: bool = False, merge: bool = False) -> list[Finding]:
    """Check that a run may save into ``directory``; the findings to merge with.

    Raises :class:`FindingsExist` when the directory holds an earlier run's
    findings and neither ``force`` (replace them) nor ``merge`` (keep them and
    add the new signatures) is given; ``ValueError`` for a file that is not a
    finding.
    """
    if not holds_findings(directory):
        return []
    if merge:
        return [finding for _, finding in load(directory)]
    if force:
        return []
    raise FindingsExist(
        f"{directory} already holds findings: --force replaces them, --merge adds to them"
    )


def save(directory: Path, findings: list[Finding]) -> list[Path]:
    """Write each finding as ``NNN-oracle-signature.json``; the paths written.

    The reproducers already in the directory are removed first, so it holds
    exactly ``findings`` (merge them first with :func:`merged` to keep them).
    """
    store = Store(directory)
    for finding in findings:
        store.put(finding)
    return store.paths()


class Store:
    """A findings directory kept true while a campaign runs.

    Each finding is written when it is found and again when it is shrunk, the
    report whenever it changes; every file is replaced atomically (written
    aside, then renamed), so a campaign stopped or killed at any moment leaves
    a directory of whole files holding everything found so far. ``earlier``
    findings (``--merge``) are written first and keep their place; a finding
    of the run replaces an earlier one of the same signature unless only the
    earlier one is shrunk.
    """

    def __init__(self, directory: Path, earlier: Sequence[Finding] = ()) -> None:
        self.directory = directory
        self._earlier_findings = list(earlier)
        self._earlier = {finding.key for finding in earlier}
        self._paths: dict[tuple[str, str], Path] = {}
        self._kept: dict[tuple[str, str], Finding] = {}
        self._opened = False

    def _open(self) -> None:
        # Nothing is touched before the run has something to say (a target that
        # cannot be reached leaves the directory as it was).
        if self._opened:
            return
        self._opened = True
        self.directory.mkdir(parents=True, exist_ok=True)
        for old in self.directory.glob(_PATTERN):
            old.unlink()
        for finding in self._earlier_findings:
            self.put(finding)

    def put(self, finding: Finding) -> Path:
        """Write ``finding`` (a new signature gets the next number); its file."""
        self._open()
        key = finding.key
        old = self._kept.get(key)
        if old is not None and key in self._earlier and old.shrunk and not finding.shrunk:
            return self._paths[key]
        path = self._paths.get(key)
        if path is None:
            path = self.directory / file_name(len(self._paths) + 1, finding)
            self._paths[key] = path
        self._kept[key] = finding
        write_atomically(path, json.dumps(finding.to_json(), indent=2) + "\n")
        return path

    def report(self, data: dict[str, Any]) -> None:
        """Write ``report.json``."""
        self._open()
        write_atomically(self.directory / "report.json", json.dumps(data, indent=2) + "\n")

    def paths(self) -> list[Path]:
        return list(self._paths.values())


def write_atomically(path: Path, text: str) -> None:
    """Replace ``path`` by a file holding ``text``: readers see the old file or the new one."""
    aside = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(aside, "w", encoding="utf-8") as file:
            file.write(text)
            file.flush()
            os.fsync(file.fileno())
        os.replace(aside, path)
    except BaseException:
        aside.unlink(missing_ok=True)
        raise


def load(path: Path) -> list[tuple[Path, Finding]]:
    """The findings in a directory (or one finding file), in name order.

    Raises ``ValueError`` naming the file for anything that is not a finding.
    """
    files = sorted(path.glob("[0-9]*.json")) if path.is_dir() else [path]
    found = []
    for file in files:
        try:
            finding = Finding.from_json(json.loads(file.read_text()))
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as error:
            raise ValueError(f"{file}: {error}") from None
        found.append((file, finding))
    return found
