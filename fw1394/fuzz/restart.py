"""Bringing a remote target back: a restart hook, and a target that uses it.

A node in another process or on a lab bench cannot be rebuilt from here, but
whoever runs the campaign usually can bring up a fresh one: a shell command
(``--restart CMD``) or, for library users, any Python callable. After a
wedge or a death the campaign runs the hook, waits until the node answers the
liveness probe and goes on with a model fresh from power-up; shrinking and
replays run it before every replay, so stateful findings start from the same
state each time.
"""

from __future__ import annotations

import os
import subprocess
import tempfile
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

from fw1394.fuzz.settings import Settings
from fw1394.fuzz.target import Observed, TargetCrash, TargetGone, Wire
from fw1394.fuzz.targets import offsets_for, open_target
from fw1394.packets import QuadletReadRequest
from fw1394.packets.fast import encode_packet

#: The environment variable that carries the worker number to a restart command.
WORKER_VARIABLE = "FW1394_FUZZ_WORKER"
#: Output of a restart command kept in a finding (its end, where errors are).
OUTPUT_LIMIT = 2000
#: Pause between two probes of a node that is not up yet.
_RETRY = 0.02


@dataclass(frozen=True)
class RestartRecord:
    """What one restart did: the command, its exit status (None: timed out), its output."""

    command: str
    status: int | None
    output: str
    #: Seconds from the start of the restart until the node answered.
    seconds: float = 0.0

    def to_json(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_json(cls, data: dict[str, Any]) -> RestartRecord:
        status = data.get("status")
        return cls(
            str(data.get("command", "")),
            int(status) if status is not None else None,
            str(data.get("output", "")),
            float(data.get("seconds", 0.0)),
        )

    def summary(self) -> str:
        status = "timed out" if self.status is None else f"exit status {self.status}"
        return f"restart `{self.command}`: {status}"


#: A restart hook: brings up a fresh target; may say what it did.
RestartHook = Callable[[], "RestartRecord | None"]


class ShellRestart:
    """Runs ``command`` in a shell; ``{worker}`` in it (and ``$FW1394_FUZZ_WORKER``)
    is the worker number.

    The command may leave the node running in the background: its output goes
    to a file, not a pipe, so a child that keeps the descriptor open does not
    hold the campaign up.
    """

    def __init__(self, command: str, worker: int = 0, timeout: float = 30.0) -> None:
        self.command = command.replace("{worker}", str(worker))
        self.worker = worker
        self.timeout = timeout

    def __call__(self) -> RestartRecord:
        env = {**os.environ, WORKER_VARIABLE: str(self.worker)}
        with tempfile.TemporaryFile() as output:
            try:
                status: int | None = subprocess.run(
                    self.command,
                    shell=True,
                    stdin=subprocess.DEVNULL,
                    stdout=output,
                    stderr=subprocess.STDOUT,
                    env=env,
                    timeout=self.timeout,
                    check=False,
                ).returncode
            except subprocess.TimeoutExpired:
                status = None
            output.seek(0)
            text = output.read().decode(errors="replace")[-OUTPUT_LIMIT:]
        return RestartRecord(self.command, status, text)


def hook_of(restart: str | RestartHook | None, worker: int = 0) -> RestartHook | None:
    """A hook from a shell command (``{worker}`` substituted) or a callable as it is."""
    if restart is None or callable(restart):
        return restart
    return ShellRestart(restart, worker)


def probe_wire(settings: Settings, node_id: int) -> Wire:
    """The liveness probe the campaign uses, as a packet of its own."""
    packet = QuadletReadRequest(
        destination_id=node_id, tlabel=0, source_id=0xFFFE, offset=offsets_for(settings).probe
    )
    return Wire(encode_packet(packet), packet, False)


def answers(exchange: Callable[[list[Wire], float], list[Observed]], probe: Wire) -> bool:
    """The node answered the probe (anything at all: an ack or a response)."""
    try:
        (seen,) = exchange([probe], 0.0)
    except TargetCrash:
        return False
    return seen.ack is not None or seen.response is not None


def wait_until_answers(target: Any, probe: Wire, limit: float) -> bool:
    """Probe ``target`` until it answers or ``limit`` seconds have passed."""
    end = time.monotonic() + limit
    while True:
        if answers(target.exchange, probe):
            return True
        if time.monotonic() >= end:
            return False
        time.sleep(_RETRY)


class TargetUnreachable(TargetGone):
    """The target never answered at all: nothing to fuzz, and no finding."""


class RestartingTarget:
    """A remote target (``udp:``, ``bus:``) that ``hook`` can bring up afresh.

    It keeps the wall clock and the twin model of a remote node
    (``restartable`` stays False: that flag means a fresh in-process node on
    simulated time) and adds ``fresh_starts``: :meth:`restart` runs the hook,
    opens the target again and waits until it answers the probe.
    """

    restartable = False
    fresh_starts = True

    def __init__(self, settings: Settings, hook: RestartHook) -> None:
        self.settings = settings
        self.hook = hook
        self.inner = open_target(settings)
        self.description = self.inner.description
        self.visibility = self.inner.visibility
        self.needs_fence = self.inner.needs_fence
        self.node_id = self.inner.node_id
        #: Restarts done so far, oldest first.
        self.records: list[RestartRecord] = []

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        return self.inner.exchange(batch, now)

    def problem(self) -> str | None:
        return self.inner.problem()

    def restart(self) -> None:
        start = time.monotonic()
        self.inner.close()
        record = self.hook() or RestartRecord("(restart hook)", 0, "")
        self.inner = open_target(self.settings)
        self.node_id = self.inner.node_id
        probe = probe_wire(self.settings, self.node_id)
        if not wait_until_answers(self.inner, probe, self.settings.dead_after):
            said = record.output.strip()[-200:]
            raise TargetGone(
                f"no answer within {self.settings.dead_after} s of a restart "
                f"({record.summary()}{': ' + said if said else ''})"
            )
        self.records.append(
            RestartRecord(record.command, record.status, record.output, time.monotonic() - start)
        )

    def close(self) -> None:
        self.inner.close()


def fresh_starts(target: Any) -> bool:
    """``target`` can start afresh for every replay (in-process, or with a restart hook)."""
    return bool(target.restartable or getattr(target, "fresh_starts", False))
