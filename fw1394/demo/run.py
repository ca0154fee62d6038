"""Bring up the demo bus, run the position loop in real time, collect the numbers."""

from __future__ import annotations

import contextlib
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass, field
from pathlib import Path

from fw1394.boards.snake2010.spec import (
    ENCODER_MIDPOINT,
    REG_WATCHDOG_PERIOD,
    STATUS_WATCHDOG_TIMEOUT,
    WATCHDOG_PRESCALER,
)
from fw1394.demo.counting import CountingPort
from fw1394.demo.pacing import Waker, tighten_timer_slack
from fw1394.demo.processes import children, per_cycle, snapshot, wait_idle
from fw1394.engine import FailureReason
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host import Board, MultiBoard, PdGains, PositionLoop
from fw1394.host.bus_port import BusPort
from fw1394.transport.bus_host import TransactionError
from fw1394.transport.media.choice import medium_name
from fw1394.transport.media.idle import ENVIRONMENT, IdleStrategy
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.supervision.launch import LaunchedBus
from fw1394.transport.supervision.stop import stop

#: The robot of thesis section 1.2: actuation unit (7 axes) and Z-Theta stage (4).
BOARDS = ("snake2010", "snake2010-ztheta")
AXES_PER_BOARD = (7, 4)
#: Watchdog period: a host stalled this long finds its amplifiers switched off.
WATCHDOG_SECONDS = 0.050
GAINS = PdGains(kp=8.0, kd=0.01)


def trajectory(axis: int) -> Callable[[float], float]:
    """A smooth target per axis: a ramp-in sine of its own amplitude and frequency."""
    amplitude = 1500.0 * (1 + axis % 4)
    frequency = 0.5 + 0.15 * axis
    phase = axis * 0.7
    angular = 2 * math.pi * frequency  # grouped as 2 * pi * frequency * t groups it

    def target(t: float) -> float:
        envelope = t / 0.5 if t < 0.5 else 1.0  # start at rest, where the motors are
        return ENCODER_MIDPOINT + envelope * amplitude * math.sin(angular * t + phase)

    return target


@dataclass
class DemoResult:
    """What one demo run measured."""

    cycles: int = 0
    seconds: float = 0.0
    #: Time from one cycle's start to the next's (s).
    periods: list[float] = field(default_factory=list)
    #: Time of each cycle's bus work: latch + apply on both boards (s).
    cycle_bus_times: list[float] = field(default_factory=list)
    #: Per sample: loop time, commanded and measured position of every axis.
    times: list[float] = field(default_factory=list)
    commanded: list[list[float]] = field(default_factory=list)
    measured: list[list[int]] = field(default_factory=list)
    watchdog_trips: int = 0
    overruns: int = 0
    #: Cycles lost to a bus reset (a node process missed its heartbeat, say).
    bus_resets: int = 0
    final_errors: list[float] = field(default_factory=list)
    bus_name: str = ""
    #: Every transaction the host started, by request kind (set-up and shut-down included).
    transactions_by_kind: dict[str, int] = field(default_factory=dict)
    #: Those of the servo loop alone, by kind.
    servo_transactions: dict[str, int] = field(default_factory=dict)
    #: Per process (host, nodes, adapter, supervisor, capture): CPU µs, wake-ups and
    #: preemptions per servo cycle (:mod:`fw1394.demo.processes`).
    processes: dict[str, dict[str, float]] = field(default_factory=dict)
    #: How the members waited for frames (:mod:`fw1394.transport.media.idle`), the
    #: medium, and whether the bus was crowded (more members on this host than CPUs).
    idle: str = ""
    medium: str = ""
    members_here: int = 0
    cpus: int = 0


Progress = Callable[[DemoResult, float], None]


def run_demo(
    seconds: float = 3.0,
    rate_hz: float = 1000.0,
    *,
    bus_name: str | None = None,
    progress: Progress | None = None,
    sample_every: int = 5,
    capture: Path | None = None,
    idle: IdleStrategy | None = None,
) -> DemoResult:
    """Run the demo for ``seconds`` of real time; every started process is stopped.

    With ``capture``, a ``fw1394 capture`` process taps the bus into that file
    for the whole run (a separate process, so the servo loop keeps its core).
    ``idle`` is how the host and the nodes wait for frames
    (:mod:`fw1394.transport.media.idle`; default ``FW1394_IDLE``, else adaptive).
    """
    config = BusConfig(name=bus_name or f"demo-{os.getpid()}")
    result = DemoResult(bus_name=config.name, medium=medium_name(config), cpus=os.cpu_count() or 1)
    # With the bus's host adapter, so `fw1394 read`/`watch` can share it while the demo runs.
    launched = LaunchedBus(
        config, len(BOARDS), board=",".join(BOARDS), node_arguments=("--adapter",)
    )
    with _idle_for_children(idle), launched as bus, _tap(config, capture) as tap:
        bus.wait_members()
        with BusPort(config, idle=idle) as bus_port:
            port = CountingPort(bus_port)
            nodes = [phy for phy, member in bus_port.nodes() if not member.host]
            robot = MultiBoard(
                [Board(port, node, axes) for node, axes in zip(nodes, AXES_PER_BOARD, strict=True)]
            )
            _retrying_bus_resets(lambda: _power_up(port, robot, nodes))
            result.idle = str(bus_port.station.idle)
            result.members_here = bus_port.station.members_here()
            pids = _demo_processes(launched, tap)
            before, counted = snapshot(pids), port.counts.copy()
            _servo(robot, result, seconds, rate_hz, progress, sample_every)
            result.processes = per_cycle(before, snapshot(pids), result.cycles)
            result.servo_transactions = dict(port.counts - counted)
            robot.set_power_control(robot.power_word(range(robot.num_axes), on=False))
            _retrying_bus_resets(robot.apply_all_outputs)
            result.transactions_by_kind = dict(port.counts)
    return result


def _demo_processes(bus: LaunchedBus, tap: subprocess.Popen[bytes] | None) -> dict[str, int]:
    """The processes a demo cycle may cost CPU in, by name."""
    pids = {"host": os.getpid()}
    nodes = {record.pid: f"node {record.board}" for record in bus.records()}
    pids.update({name: pid for pid, name in nodes.items()})
    if bus.process is not None:
        pids["supervisor"] = bus.process.pid
        others = [pid for pid in children(bus.process.pid) if pid not in nodes]
        pids.update({f"adapter {n}" if n else "adapter": pid for n, pid in enumerate(others)})
    if tap is not None:
        pids["capture"] = tap.pid
    return pids


@contextlib.contextmanager
def _idle_for_children(idle: IdleStrategy | None) -> Iterator[None]:
    # The node processes take their strategy from the environment they inherit.
    if idle is None:
        yield
        return
    before = os.environ.get(ENVIRONMENT)
    os.environ[ENVIRONMENT] = str(idle)
    try:
        yield
    finally:
        if before is None:
            del os.environ[ENVIRONMENT]
        else:
            os.environ[ENVIRONMENT] = before


@contextlib.contextmanager
def _tap(config: BusConfig, path: Path | None) -> Iterator[subprocess.Popen[bytes] | None]:
    if path is None:
        yield None
        return
    # The capture's header marks its tap listening; a file left by an earlier run
    # would say so before this capture even started, and its first packets be lost.
    path.unlink(missing_ok=True)
    command = [sys.executable, "-m", "fw1394.capture.formats.bus_recorder", config.name, str(path)]
    tap = subprocess.Popen(command, stdin=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        # The capture writes its file header once its tap listens; traffic waits for it.
        limit = time.monotonic() + 20.0
        while not (path.exists() and path.stat().st_size) and tap.poll() is None:
            if time.monotonic() > limit:
                break
            time.sleep(0.02)
        yield tap
    finally:
        # SIGINT is the capture's clean stop: it finishes the record and the file, but
        # drops what its socket still holds, so a capture that lags is let catch up.
        wait_idle(tap.pid)
        stop(tap, ask=signal.SIGINT)


def _retrying_bus_resets(action: Callable[[], None], attempts: int = 3) -> None:
    # A bus reset fails the transactions in flight; setup steps are idempotent.
    for attempt in range(attempts):
        try:
            action()
            return
        except TransactionError as error:
            if error.reason != FailureReason.bus_reset or attempt == attempts - 1:
                raise


def _power_up(port: CountingPort, robot: MultiBoard, nodes: list[int]) -> None:
    period = round(WATCHDOG_SECONDS * TICKS_PER_SECOND / WATCHDOG_PRESCALER)
    for node in nodes:
        port.write_quadlet(node, REG_WATCHDOG_PERIOD, period)
    for axis in range(robot.num_axes):
        robot.set_encoder_preload(axis, ENCODER_MIDPOINT)
    robot.set_power_control(robot.power_word(range(robot.num_axes), on=True))
    robot.apply_all_outputs()


def _servo(
    robot: MultiBoard,
    result: DemoResult,
    seconds: float,
    rate_hz: float,
    progress: Progress | None,
    sample_every: int,
) -> None:
    targets = [trajectory(axis) for axis in range(robot.num_axes)]
    loop = PositionLoop(robot, targets, GAINS, rate_hz=rate_hz)
    period = 1.0 / rate_hz
    start = previous = deadline = time.perf_counter()
    end = start + seconds
    next_report = start
    tripped = False
    cycle = 0
    tighten_timer_slack()
    waker = Waker()
    while (now := time.perf_counter()) < end:
        if now < deadline:
            waker.wait_until(deadline)
            continue
        if now - deadline > period:
            # A missed deadline: count it and resume from now rather than
            # running the missed cycles back to back.
            result.overruns += 1
            deadline = now
        deadline += period
        if cycle:
            result.periods.append(now - previous)
        previous = now
        # The boards' motors run in real time, so the trajectories do too.
        loop.cycle = round((now - start) * rate_hz)
        loop_time = loop.time
        try:
            errors = loop.step()
        except TransactionError as error:
            if error.reason != FailureReason.bus_reset:
                raise
            result.bus_resets += 1  # the cycle is lost; the next one starts afresh
            continue
        result.cycle_bus_times.append(time.perf_counter() - now)
        watchdog = robot.get_status() & (STATUS_WATCHDOG_TIMEOUT | STATUS_WATCHDOG_TIMEOUT << 32)
        if watchdog and not tripped:
            # The boards switched every amplifier off; count it and switch them
            # back on, which also clears the flag (thesis section 6.3).
            result.watchdog_trips += 1
            robot.set_power_control(robot.power_word(range(robot.num_axes), on=True))
        tripped = bool(watchdog)
        if cycle % sample_every == 0:
            result.times.append(loop_time)
            result.commanded.append([target(loop_time) for target in targets])
            result.measured.append(robot.get_encoder_positions())
        cycle += 1
        result.cycles = cycle
        result.final_errors = errors
        if progress is not None and now >= next_report:
            progress(result, now - start)
            next_report = now + 0.25
    result.seconds = time.perf_counter() - start
