"""Virtual-bus latency and throughput, next to a raw Python UDP ping-pong of the same run.

    python bench/bus.py            # full run (about a minute on two cores)
    python bench/bus.py --quick    # fewer samples and bus sizes
    python bench/bus.py --json     # one JSON object instead of the report
    python bench/bus.py --mac      # what the keyed MAC costs per frame and per read
    python bench/bus.py --syscalls # CPU per sendto / recv: the floor of a read's CPU
    python bench/bus.py --mechanisms   # transports compared, shared memory included
    python bench/bus.py --doorbells    # the shared medium's wake-ups: datagram vs semaphore
    python bench/bus.py --work     # a read's Python alone: host and node in one process
    python bench/bus.py --idle block   # every process of the run blocks in recv
    python bench/bus.py --pin      # this process on one CPU, its peers on the others

Measures, between this process (the host) and node processes on loopback:
quadlet read and write round trips (p50, p99), 512-quadlet block reads
(sequential, and pipelined four and sixteen deep), and quadlet-read latency as the bus
grows to 63 members (62 nodes and the host). The raw ping-pong, quadlet reads
and writes and 4-byte block reads (block read base latency) are timed in
interleaved rounds (A B C D A B C D ...), so each ratio to raw comes from the
same minutes of a shared machine; every process waits by the same idle strategy
(``FW1394_IDLE`` or ``--idle``). Each round starts once the previous round's
peer has stopped polling, after a few uncounted calls, and the context
switches per call of each kind (wake-ups here and in its peer, preemptions
here) say which regime it ran in: a ratio whose halves differ is flagged.
The read's three frames with no work done (the floor) are timed in the same
rounds. CPU time per call (user + kernel, this process
and the node's) is printed too: it moves much less with the machine's load.
Targets from the issue are printed beside the results; they are not asserted.
"""

from __future__ import annotations

import argparse
import fcntl
import json
import mmap
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from contextlib import ExitStack, contextmanager
from functools import partial
from typing import Any

import posix_ipc

from fw1394.boards.config_rom import with_config_rom
from fw1394.boards.memory.board import MemorySpace
from fw1394.experiments.frame_floor import FrameFloor
from fw1394.experiments.regime import Regime, same_regime, settle, settle_time, switches
from fw1394.experiments.timing import SWITCH_WARMUP, cpu_split, pin
from fw1394.host.bus_port import BusPort
from fw1394.node.process import Node, NodeOptions
from fw1394.packets import QuadletReadRequest
from fw1394.packets.fast import encode_packet
from fw1394.transport.media.choice import ENVIRONMENT as MEDIUM_ENV
from fw1394.transport.media.idle import BLOCK as BLOCK_IDLE
from fw1394.transport.media.idle import Waiter, default_idle, parse_idle
from fw1394.transport.media.shared_memory import SharedMedium
from fw1394.transport.media.udp import MAX_FRAME, Medium
from fw1394.transport.node_express import node_turn
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import Timing
from fw1394.transport.sansio.wire import KIND_OFFSET, FrameHeader, FrameKind
from fw1394.transport.supervision.stop import stop

BLOCK = 2048  # 512 quadlets
NODE_COUNTS = (1, 2, 4, 8, 16, 32, 62)
QUICK_COUNTS = (1, 8, 62)
# Heartbeats are slowed down for the big buses: 62 Python processes starting at once
# on two cores would otherwise miss leases and churn the bus while it is measured.
TIMING_ARGS = ("--heartbeat", "0.2", "--lease", "3.0")
TIMING = Timing(heartbeat=0.2, lease=3.0)


def percentiles(samples: list[float]) -> dict[str, float]:
    ordered = sorted(samples)
    return {
        "p50_us": round(ordered[len(ordered) // 2] * 1e6, 1),
        "p99_us": round(ordered[int(len(ordered) * 0.99)] * 1e6, 1),
    }


def cpu_ns(pid: int | str) -> int | None:
    """CPU time process ``pid`` (or "self") has run so far, in ns; None off Linux.

    Latency on a shared machine moves with whatever else runs; the CPU time each
    side spends per transaction (user and kernel) moves much less, so before and
    after a change compare better by it.
    """
    try:
        with open(f"/proc/{pid}/schedstat") as stats:
            return int(stats.read().split()[0])
    except (OSError, ValueError, IndexError):
        return None


def timed(action: Callable[[], object], count: int) -> list[float]:
    samples = []
    clock = time.perf_counter
    for _ in range(count):
        start = clock()
        action()
        samples.append(clock() - start)
    return samples


# -- raw UDP ping-pong --------------------------------------------------------------------
# The echo waits the way bus members do (FW1394_IDLE, inherited), so that both halves of
# a ratio pay the same wake-ups.
ECHO = """
import socket, sys
from fw1394.transport.media.idle import Waiter, default_idle, parse_idle
s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
s.bind(("127.0.0.1", 0))
s.setsockopt(socket.SOL_SOCKET, socket.SO_RCVTIMEO, (1).to_bytes(8, "little") + bytes(8))
print(s.getsockname()[1], flush=True)
peer = ("127.0.0.1", int(sys.stdin.readline()))
wait = Waiter(s, default_idle(), 1.0).receive
while True:
    data = wait(4096)
    if data is None:
        continue
    if data == b"stop":
        break
    s.sendto(data, peer)
"""


class RawEcho:
    """A raw Python UDP ping-pong partner, kept for the whole run (rounds interleave)."""

    def __init__(self) -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(1.0)
        self.echo = subprocess.Popen(
            [sys.executable, "-c", ECHO], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
        )
        assert self.echo.stdout is not None and self.echo.stdin is not None
        self.peer = ("127.0.0.1", int(self.echo.stdout.readline()))
        self.echo.stdin.write(f"{self.sock.getsockname()[1]}\n")
        self.echo.stdin.flush()
        self.sock.settimeout(None)
        Medium.set_poll_interval(self.sock, 1.0)
        self._wait = Waiter(self.sock, default_idle(), 1.0)
        self._payload = bytes(40)

    def once(self) -> None:
        self.sock.sendto(self._payload, self.peer)
        self._wait.traffic()
        self._wait.receive(4096)

    def close(self) -> None:
        self.sock.sendto(b"stop", self.peer)
        self.sock.close()
        stop(self.echo, ask=None)  # asked by the "stop" datagram


def raw_ping_pong(count: int) -> dict[str, float]:
    echo = RawEcho()
    try:
        timed(echo.once, 200)
        return percentiles(timed(echo.once, count))
    finally:
        echo.close()


def interleaved(
    actions: dict[str, Callable[[], object]],
    count: int,
    rounds: int,
    peers: dict[str, list[int]] | None = None,
) -> tuple[dict[str, list[float]], dict[str, Regime]]:
    """``count`` timings of each action, taken in ``rounds`` rounds A B C A B C ...

    Both halves of a ratio then come from the same minutes of a shared machine.
    Each round starts once the previous one's peer has stopped polling, after
    ``SWITCH_WARMUP`` uncounted calls; the context switches of each action's
    rounds (this process's and its ``peers``') say which regime it ran in.
    """
    samples: dict[str, list[float]] = {name: [] for name in actions}
    regimes = {name: Regime() for name in actions}
    per_round = max(1, count // rounds)
    for _ in range(rounds):
        for name, action in actions.items():
            pids = (peers or {}).get(name, [])
            settle()
            before = switches(pids)
            timed(action, SWITCH_WARMUP)
            samples[name] += timed(action, per_round)
            regimes[name].add(before, switches(pids), SWITCH_WARMUP + per_round)
    return samples, regimes


# -- mechanisms: why multicast groups with a kernel filter ---------------------------------
def _forked(loop: Callable[[], None]) -> int:
    pid = os.fork()
    if pid == 0:
        try:
            loop()
        finally:
            os._exit(0)
    return pid


def _group_socket(config: BusConfig, member_id: int, phy: int, filtered: bool) -> Medium:
    medium = Medium(config)
    if filtered:
        medium.filter_as_member(member_id, phy, False)
    else:
        medium.filter_as_tap()  # passes every frame of the bus: no link-layer filtering
    medium.set_poll_interval(medium.sock, 1.0)
    return medium


def multicast_ping_pong(idle: int, filtered: bool, count: int) -> dict[str, float]:
    """Round trips between two group members while ``idle`` more members listen."""
    config = BusConfig(f"mech{os.getpid()}")
    # Physical IDs 1 (this process) and 2 (the echo) use member ids 101 and 102.
    frame_to = {
        phy: FrameHeader(FrameKind.async_packet, config.tag, 103 - phy, 0, 3 - phy, phy).pack()
        for phy in (1, 2)
    }

    def listener(phy: int, echo: bool) -> Callable[[], None]:
        def loop() -> None:
            medium = _group_socket(config, 100 + phy, phy, filtered)
            while True:
                frame = medium.receive()
                if echo and frame is not None and frame[17] == phy:
                    medium.send(frame_to[1])

        return loop

    idle_phys = [phy for phy in range(63) if phy not in (1, 2)][:idle]
    pids = [_forked(listener(phy, False)) for phy in idle_phys]
    me = _group_socket(config, 101, 1, filtered)
    pids.append(_forked(listener(2, True)))
    try:
        time.sleep(0.3 + idle * 0.01)

        me.set_poll_interval(me.sock, 0.5)

        def once() -> None:
            me.send(frame_to[2])
            for _ in range(4):  # a datagram lost in a full queue costs 0.5 s, not a hang
                frame = me.receive()
                if frame is not None and frame[17] == 1:
                    return

        timed(once, 200)
        return percentiles(timed(once, count))
    finally:
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)
        me.close()


@contextmanager
def subaction_floor() -> Iterator[tuple[Callable[[], None], int]]:
    """A quadlet read's three frames on the bus, with no work done for them
    (:mod:`fw1394.experiments.frame_floor`, as ``fw1394 bench`` times them): the
    least any quadlet read on this bus can cost with Python at both ends. Yields
    one exchange and the responder's pid."""
    floor = FrameFloor()
    try:
        timed(floor.exchange, 200)
        yield floor.exchange, floor.pid
    finally:
        floor.close()


def hub_relay(count: int) -> dict[str, float]:
    """Round trips through a repeater process (host -> hub -> node -> hub -> host)."""
    hub, host, node = (socket.socket(socket.AF_INET, socket.SOCK_DGRAM) for _ in range(3))
    for sock in (hub, host, node):
        sock.bind(("127.0.0.1", 0))

    def relay() -> None:
        while True:
            data, peer = hub.recvfrom(4096)
            hub.sendto(
                data, node.getsockname() if peer == host.getsockname() else host.getsockname()
            )

    def echo() -> None:
        while True:
            node.sendto(node.recv(4096), hub.getsockname())

    pids = [_forked(relay), _forked(echo)]
    try:

        def once() -> None:
            host.sendto(bytes(40), hub.getsockname())
            host.recv(4096)

        timed(once, 200)
        return percentiles(timed(once, count))
    finally:
        for pid in pids:
            os.kill(pid, signal.SIGKILL)
            os.waitpid(pid, 0)


def shared_memory_ping_pong(count: int, frames: int = 2) -> dict[str, float]:
    """Exchanges of ``frames`` 40-byte frames through one shared page, both ends polling.

    What a medium without a system call per frame would cost: each end spins on
    the other's sequence number, as a polling member spins on its socket. Two
    frames are a raw round trip; three a quadlet read's (request, ack with the
    response, the requester's ack), the third written but not waited for, as a
    node does not wake for acks. Not a transport of fw1394: a measure of the next
    step's floor.
    """
    page = mmap.mmap(-1, mmap.PAGESIZE)  # anonymous and shared: the child sees it
    payload = bytes(40)

    def answer() -> None:
        seen = bytes(8)
        while True:
            asked = page[0:8]
            if asked != seen:
                seen = asked
                page[72:112] = page[8:48]
                page[64:72] = asked

    pid = _forked(answer)
    sent = 0

    def once() -> None:
        nonlocal sent
        sent += 1
        mark = sent.to_bytes(8, "little")
        page[8:48] = payload
        page[0:8] = mark
        while page[64:72] != mark:
            pass
        if frames == 3:
            page[128:168] = payload  # the requester's ack: nobody waits for it
            page[120:128] = mark

    try:
        timed(once, 2000)
        return percentiles(timed(once, count))
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        page.close()


def shared_medium_ping_pong(count: int, idle: str) -> dict[str, float]:
    """Round trips of a 40-byte frame between two members of a bus on the shared-memory
    medium (:mod:`fw1394.transport.media.shared_memory`), both waiting by ``idle``."""
    config = BusConfig(f"mechshm{os.getpid()}", key=b"")
    strategy = parse_idle(idle)
    frame_to = {
        phy: FrameHeader(FrameKind.async_packet, config.tag, 103 - phy, 0, 3 - phy, phy).pack()
        + bytes(16)
        for phy in (1, 2)
    }

    def echo() -> None:
        medium = SharedMedium(config, 0.5, strategy)
        medium.filter_as_member(102, 2, False)
        while True:
            if medium.receive() is not None:
                medium.send(frame_to[1])

    me = SharedMedium(config, 0.5, strategy)
    me.filter_as_member(101, 1, False)
    pid = _forked(echo)
    try:
        time.sleep(0.3)

        def once() -> None:
            me.send(frame_to[2])
            while me.receive() is None:
                pass

        timed(once, 200)
        return percentiles(timed(once, count))
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        me.close()


def lock_pair_us(count: int = 20000) -> float:
    """An uncontended ``flock``/``funlock`` pair: what every frame written costs to order."""
    with tempfile.TemporaryFile() as file:
        fd, lock, unlock = file.fileno(), fcntl.LOCK_EX, fcntl.LOCK_UN
        start = time.perf_counter()
        for _ in range(count):
            fcntl.flock(fd, lock)
            fcntl.flock(fd, unlock)
        return round((time.perf_counter() - start) / count * 1e6, 3)


def doorbell_round_trips(kind: str, count: int) -> dict[str, Any]:
    """A sleeper woken and waking back, ``count`` times, by the shared medium's two
    doorbells: ``datagram`` (an empty datagram to a Unix socket, what a member that
    selects is rung with) or ``semaphore`` (a POSIX semaphore, a futex: what a
    member blocked in its own receive waits on). Both ends block; p50 of a round
    trip and the CPU (user + kernel) each end spends per round trip."""
    if kind == "semaphore":
        name = f"/fw1394-bench-{os.getpid()}"
        here, there = (
            posix_ipc.Semaphore(f"{name}-{end}", posix_ipc.O_CREX, 0o600, 0) for end in "ab"
        )
        for bell in (here, there):
            bell.unlink()  # the forked child keeps them open
        ring_there, ring_here = there.release, here.release

        def wait_here() -> None:
            here.acquire(1.0)

        def wait_there() -> None:
            there.acquire(1.0)

    else:
        sockets = [socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM) for _ in range(3)]
        for end, sock in zip("ab", sockets, strict=False):
            sock.bind(f"\0fw1394-bench-{os.getpid()}-{end}".encode())
        ringer = sockets[2]
        here_name, there_name = (sock.getsockname() for sock in sockets[:2])

        def ring_there() -> None:
            ringer.sendto(b"", there_name)

        def ring_here() -> None:
            ringer.sendto(b"", here_name)

        def wait_here() -> None:
            sockets[0].recv(16)

        def wait_there() -> None:
            sockets[1].recv(16)

    def answer() -> None:
        while True:
            wait_there()
            ring_here()

    def once() -> None:
        ring_there()
        wait_here()

    pid = _forked(answer)
    try:
        timed(once, 500)
        result: dict[str, Any] = percentiles(timed(once, count))
        result["cpu_us"] = cpu_per_call(once, count, pid)
        return result
    finally:
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)


def doorbells(count: int) -> dict[str, Any]:
    """The two doorbells alternated over three rounds each, on the same minutes."""
    results: dict[str, list[dict[str, Any]]] = {"datagram": [], "semaphore": []}
    for _ in range(3):
        for kind, rounds in results.items():
            rounds.append(doorbell_round_trips(kind, count))
    return {"idle": "block", "rounds": results}


def mechanisms(count: int) -> dict[str, Any]:
    results: dict[str, Any] = {
        "doorbells": doorbells(count),
        "unicast": raw_ping_pong(count),
        "hub_relay": hub_relay(count),
        "shared_memory_2_frames": shared_memory_ping_pong(count, 2),
        "shared_memory_3_frames": shared_memory_ping_pong(count, 3),
        "shared_medium_spin": shared_medium_ping_pong(count, "spin"),
        "shared_medium_block": shared_medium_ping_pong(count, "block"),
        "shared_medium_adaptive": shared_medium_ping_pong(count, "adaptive"),
        "flock_pair_us": lock_pair_us(),
    }
    for idle in (0, 6, 30, 61):
        results[f"multicast_{idle}_idle"] = {
            "unfiltered": multicast_ping_pong(idle, False, count),
            "kernel_filter": multicast_ping_pong(idle, True, count),
        }
    return results


# -- bus ------------------------------------------------------------------------------------
class Nodes:
    """Node processes of the bench's bus; they die with this process."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.processes: list[subprocess.Popen[bytes]] = []

    def grow(self, count: int) -> None:
        while len(self.processes) < count:
            rank = len(self.processes)
            command = [sys.executable, "-m", "fw1394.cli.bus", "node", "run", "--name", self.name]
            command += ["--rank", str(rank), "--board-id", str(rank % 16), "--quiet"]
            command += ["--parent-pid", str(os.getpid()), *TIMING_ARGS]
            self.processes.append(subprocess.Popen(command, stdin=subprocess.DEVNULL))

    def stop(self) -> None:
        stop(self.processes)


def wait_for_nodes(port: BusPort, count: int, timeout: float = 120.0) -> None:
    limit = time.monotonic() + timeout
    while len(port.nodes()) < count:
        if time.monotonic() > limit:
            raise RuntimeError(f"only {len(port.nodes())} of {count} nodes joined")
        port.poll(0.1)
    port.poll(0.3)  # let the last self-ID phase and any stragglers settle


def block_throughput(port: BusPort, count: int, depth: int) -> float:
    """Effective Mbit/s of block reads with ``depth`` outstanding."""
    start = time.perf_counter()
    pending = [port.start_read_block(0, 0, BLOCK) for _ in range(depth)]
    done = 0
    while pending:
        port.wait(pending.pop(0))
        done += 1
        if done + len(pending) < count:
            pending.append(port.start_read_block(0, 0, BLOCK))
    elapsed = time.perf_counter() - start
    return round(done * BLOCK * 8 / elapsed / 1e6, 1)


def cpu_per_call(action: Callable[[], object], count: int, node_pid: int) -> dict[str, float]:
    """CPU time (user + kernel) per call in this process and in the node, in us."""
    before = cpu_ns("self"), cpu_ns(node_pid)
    for _ in range(count):
        action()
    after = cpu_ns("self"), cpu_ns(node_pid)
    spent = [b - a for a, b in zip(before, after, strict=True) if a and b]
    if len(spent) != 2:
        return {}
    host, node = (round(ns / count / 1e3, 1) for ns in spent)
    return {"host": host, "node": node}


MEDIA = ("shm", "udp")
#: The figures each medium gets in the interleaved rounds.
KINDS = ("quadlet_read", "quadlet_write", "block_read_4")


@contextmanager
def on_medium(medium: str) -> Iterator[None]:
    """Members started or joined inside use ``medium`` (``FW1394_MEDIUM``)."""
    before = os.environ.get(MEDIUM_ENV)
    os.environ[MEDIUM_ENV] = medium
    try:
        yield
    finally:
        if before is None:
            del os.environ[MEDIUM_ENV]
        else:
            os.environ[MEDIUM_ENV] = before


def run(quick: bool, rounds: int, pin_cpus: bool = False, scale: bool = True) -> dict[str, Any]:
    """Both media side by side: a bus of one node on each, timed in the same rounds
    as the raw ping-pong and the frame floor."""
    samples = 2000 if quick else 10000
    # Pinned: every process started from here inherits the peers' CPUs; this one then
    # takes the first CPU alone, so the two ends of a round trip never share one.
    split = cpu_split() if pin_cpus else None
    if split is not None:
        pin([0], split[1])
    results: dict[str, Any] = {
        "cpus": os.cpu_count(),
        "pinned": split is not None,
        "idle": str(default_idle()),
        "rounds": rounds,
        "round_switch_settle_ms": round(settle_time(default_idle()) * 1000, 3),
        "load_average_before": os.getloadavg()[0],
        "media": {},
    }
    nodes = {medium: Nodes(f"bench{os.getpid()}{medium}") for medium in MEDIA}
    echo = RawEcho()
    try:
        with ExitStack() as stack:
            ports: dict[str, BusPort] = {}
            for medium in MEDIA:
                with on_medium(medium):
                    nodes[medium].grow(1)
                    ports[medium] = stack.enter_context(
                        BusPort(BusConfig(nodes[medium].name), timing=TIMING)
                    )
            floor_once, floor_pid = stack.enter_context(subaction_floor())
            for port in ports.values():
                wait_for_nodes(port, 1)
            node_pids = {medium: nodes[medium].processes[0].pid for medium in MEDIA}
            if split is not None:
                pin([0], split[0])
            actions: dict[str, Callable[[], object]] = {
                "raw_udp": echo.once,
                "subaction_floor": floor_once,
            }
            peers = {"raw_udp": [echo.echo.pid], "subaction_floor": [floor_pid]}
            for medium, port in ports.items():
                actions[f"{medium}:quadlet_read"] = partial(port.read_quadlet, 0, 0)
                actions[f"{medium}:quadlet_write"] = partial(port.write_quadlet, 0, 0, 1)
                actions[f"{medium}:block_read_4"] = partial(port.read_block, 0, 0, 4)
                for kind in KINDS:
                    peers[f"{medium}:{kind}"] = [node_pids[medium]]
            interleaved(actions, 500, 5)  # warm-up
            timings, regimes = interleaved(actions, samples, rounds, peers)
            for key in ("raw_udp", "subaction_floor"):
                results[key] = percentiles(timings[key])
            raw = results["raw_udp"]["p50_us"]
            results["subaction_floor"]["ratio_p50"] = round(
                results["subaction_floor"]["p50_us"] / raw, 2
            )
            results["regime"] = {key: regime.as_dict() for key, regime in regimes.items()}
            results["same_regime_as_raw"] = {
                key: same_regime(regimes["raw_udp"], regime)
                for key, regime in regimes.items()
                if key != "raw_udp"
            }
            # The floor of the CPU figures: a raw round trip's sendto and recv.
            results["raw_udp"]["cpu_us"] = cpu_per_call(echo.once, samples, echo.echo.pid)
            blocks = 500 if quick else 3000
            for medium, port in ports.items():
                figures: dict[str, Any] = {}
                for kind in KINDS:
                    figures[kind] = percentiles(timings[f"{medium}:{kind}"])
                figures["ratios_p50"] = {
                    kind: round(figures[kind]["p50_us"] / raw, 2) for kind in KINDS
                }
                figures["quadlet_read"]["cpu_us"] = cpu_per_call(
                    partial(port.read_quadlet, 0, 0), samples, node_pids[medium]
                )
                figures["block_read_512_cpu_us"] = cpu_per_call(
                    partial(port.read_block, 0, 0, BLOCK), samples // 4, node_pids[medium]
                )
                figures["block_read_mbit_s"] = {
                    "sequential": block_throughput(port, blocks, 1),
                    "pipelined_4": block_throughput(port, blocks, 4),
                    "pipelined_16": block_throughput(port, blocks, 16),
                }
                results["media"][medium] = figures
            shm = results["media"]["shm"]["quadlet_read"]["p50_us"]
            results["shm_vs_udp_read_p50"] = round(
                shm / results["media"]["udp"]["quadlet_read"]["p50_us"], 2
            )
            # Scale on the default medium only: 62 more node processes per medium
            # would take longer than the rest of the run.
            port, scaling = ports["shm"], {}
            for count in (QUICK_COUNTS if quick else NODE_COUNTS) if scale else (1,):
                with on_medium("shm"):
                    nodes["shm"].grow(count)
                if split is not None:
                    pin([process.pid for process in nodes["shm"].processes], split[1])
                wait_for_nodes(port, count)
                timed(lambda: port.read_quadlet(0, 0), 200)
                reads = timed(lambda: port.read_quadlet(0, 0), samples // 4)
                scaling[str(count + 1)] = percentiles(reads)
                scaling[str(count + 1)]["generation"] = port.generation
            results["media"]["shm"]["members_vs_read"] = scaling
    finally:
        echo.close()
        for group in nodes.values():
            group.stop()
    results["load_average_after"] = os.getloadavg()[0]
    return results


def _work_per_read(name: str, count: int) -> float:
    """CPU per quadlet read, in us, of a host and a memory node both in this process."""
    config = BusConfig(name)
    space = with_config_rom(MemorySpace(), bus=name, board_id=0, rank=0, model="memory")
    node = Node(space, NodeOptions(config=config, rank=0, timing=TIMING, idle=BLOCK_IDLE))
    turn = node_turn(node.link)
    joining = True

    def serve() -> None:
        while joining:
            turn()

    server = threading.Thread(target=serve)
    server.start()
    port: BusPort | None = None
    try:
        port = BusPort(BusConfig(name), timing=TIMING)
        wait_for_nodes(port, 1)
    finally:
        joining = False
        server.join()
        if port is None:
            node.station.close()
    try:
        medium = node.station.medium
        # The node's turns run right after the host's request leaves, until the node
        # has taken every frame waiting for it, so no process ever sleeps or wakes.
        if isinstance(medium, SharedMedium):

            def waiting() -> bool:
                return medium.position < medium.head

        else:

            def waiting() -> bool:
                return bool(select.select([medium.sock], [], [], 0)[0])

        station = port.station
        put = station._put  # the bench's hook: no member has another way in

        def put_then_serve(frame: bytes) -> None:
            put(frame)
            if frame[KIND_OFFSET] == FrameKind.async_packet:
                while waiting():
                    turn()

        station._put = put_then_serve
        for _ in range(count // 10):
            port.read_quadlet(0, 0)
        start = time.process_time()
        for _ in range(count):
            port.read_quadlet(0, 0)
        return round((time.process_time() - start) / count * 1e6, 2)
    finally:
        port.close()
        node.station.close()


def python_work(count: int, rounds: int = 3) -> dict[str, Any]:
    """The Python of a quadlet read, both ends, without the wake-ups: host and node in
    this process, the node's turn taken as soon as the request is on the medium.
    Alternated between the media over ``rounds`` rounds. On UDP the figure includes
    the two ``select`` calls per read that find the node's frames queued."""
    results: dict[str, list[float]] = {medium: [] for medium in MEDIA}
    for round_ in range(rounds):
        for medium, figures in results.items():
            with on_medium(medium):
                figures.append(_work_per_read(f"benchwork{os.getpid()}{medium}{round_}", count))
    return {"cpu_us_per_read_host_and_node": results}


def mac_cost(quick: bool) -> dict[str, Any]:
    """The keyed bus's price: sealing and verifying one frame, and a quadlet read on a
    keyed and an insecure bus of one node each, measured in alternating rounds."""
    import tempfile
    from pathlib import Path

    from fw1394.transport.sansio.seal import Sealer, Verifier
    from fw1394.transport.supervision.bus_key import new_key
    from fw1394.transport.supervision.launch import LaunchedBus

    key = new_key()
    header = FrameHeader(FrameKind.async_packet, 1, 2, 3, 1, 0).pack()
    read = encode_packet(QuadletReadRequest(destination_id=0xFFC0, tlabel=1, offset=0))
    per_frame: dict[str, float] = {}
    for label, frame in (
        ("quadlet_read_frame", header + read),
        ("block_2k_frame", header + bytes(BLOCK)),
    ):
        sealer, verifier = Sealer(key), Verifier(key)
        count = 20000 if quick else 100000
        sealed = [sealer.seal(frame) for _ in range(count)]
        start = time.perf_counter()
        for _ in range(count):
            sealer.seal(frame)
        seal = (time.perf_counter() - start) / count
        start = time.perf_counter()
        for raw in sealed:
            verifier.open(raw)
        check = (time.perf_counter() - start) / count
        per_frame[label + "_seal_us"] = round(seal * 1e6, 2)
        per_frame[label + "_verify_us"] = round(check * 1e6, 2)
    rounds, per_round = (6, 500) if quick else (20, 1000)
    node_args = ("--heartbeat", "0.2", "--lease", "3.0")
    samples: dict[str, list[float]] = {"keyed": [], "insecure": []}
    with tempfile.TemporaryDirectory() as root:
        buses = {
            mode: LaunchedBus(
                BusConfig(f"benchmac{os.getpid()}{mode[0]}"),
                1,
                root=Path(root),
                node_arguments=node_args,
                key=key if mode == "keyed" else None,
            )
            for mode in samples
        }
        ports: dict[str, BusPort] = {}
        try:
            for mode, bus in buses.items():
                bus.start()
                ports[mode] = BusPort(bus.member_config, timing=TIMING)
                wait_for_nodes(ports[mode], 1)
                timed(partial(ports[mode].read_quadlet, 0, 0), 300)
            for _ in range(rounds):  # interleaved: both see the same machine
                for mode, port in ports.items():
                    samples[mode] += timed(partial(port.read_quadlet, 0, 0), per_round)
        finally:
            for port in ports.values():
                port.close()
            for bus in buses.values():
                bus.stop()
    reads = {mode: percentiles(values) for mode, values in samples.items()}
    ratio = reads["keyed"]["p50_us"] / reads["insecure"]["p50_us"]
    return {"per_frame": per_frame, "quadlet_read": reads, "keyed_vs_insecure_p50": round(ratio, 3)}


def syscall_costs(rounds: int, count: int = 1000) -> dict[str, Any]:
    """CPU per system call of a bus member's data path, and the least a read can cost.

    Two members of one bus in this process: ``sendto`` of a request-sized frame
    (its delivery into the receiver's socket is charged to the sender, in the
    kernel), ``recv`` of a queued frame, and a poll that finds nothing (what an
    adaptive member pays per try). A quadlet read makes the host send twice (the
    request and its ack of the response) and receive once, the node receive once
    and send once: their sums are the CPU floor of a read before any Python work
    or wake-up. ``count`` frames per round stay well inside the socket's buffer.
    """
    config = BusConfig(f"sys{os.getpid()}")
    sender, receiver = Medium(config), Medium(config)
    sender.filter_as_member(101, 1, False)
    receiver.filter_as_member(102, 2, False)
    frame = FrameHeader(FrameKind.async_packet, config.tag, 101, 0, 1, 2).pack() + bytes(16)
    recv = receiver.sock.recv
    clock = time.process_time_ns
    totals = {"sendto_us": 0, "recv_queued_us": 0, "recv_empty_us": 0}
    try:
        for _ in range(rounds):
            start = clock()
            for _ in range(count):
                sender.send(frame)
            middle = clock()
            for _ in range(count):
                recv(MAX_FRAME, socket.MSG_DONTWAIT)  # raises if a frame was lost
            end = clock()
            for _ in range(count):
                # As the members poll: a try statement, not a context manager per call.
                try:  # noqa: SIM105
                    recv(MAX_FRAME, socket.MSG_DONTWAIT)
                except BlockingIOError:
                    pass
            totals["sendto_us"] += middle - start
            totals["recv_queued_us"] += end - middle
            totals["recv_empty_us"] += clock() - end
    finally:
        sender.close()
        receiver.close()
    per_call = {key: round(ns / rounds / count / 1e3, 2) for key, ns in totals.items()}
    send, take = per_call["sendto_us"], per_call["recv_queued_us"]
    return {
        **per_call,
        "read_floor_host_us": round(2 * send + take, 2),
        "read_floor_node_us": round(send + take, 2),
        "goal_host_us": 10,
        "goal_node_us": 8,
    }


def report(results: dict[str, Any]) -> None:
    raw = results["raw_udp"]["p50_us"]
    print(
        f"cpus: {results['cpus']}, idle strategy: {results['idle']}, load average "
        f"{results['load_average_before']} before, {results['load_average_after']} after; "
        f"raw and both media timed in {results['rounds']} interleaved rounds"
        + ("; this process on one CPU, its peers on the others" if results["pinned"] else "")
    )
    print(f"raw Python UDP ping-pong    p50 {raw:7.1f} us  p99 {results['raw_udp']['p99_us']} us")
    floor = results["subaction_floor"]
    print(
        f"  the read's three frames on UDP with no work done (the floor): p50 "
        f"{floor['p50_us']:.1f} us, {floor['ratio_p50']:.2f}x raw"
    )
    goals = {"quadlet_read": 1.0, "quadlet_write": 0.8, "block_read_4": 1.2}
    print(f"{'':27} {'shared memory':>30}   {'UDP multicast':>30}   goal")
    for kind, goal in goals.items():
        cells = []
        for medium in MEDIA:
            row = results["media"][medium][kind]
            ratio = results["media"][medium]["ratios_p50"][kind]
            cells.append(f"p50 {row['p50_us']:6.1f} p99 {row['p99_us']:6.0f} x{ratio:.2f} raw")
        print(f"{kind:<27} {cells[0]:>30}   {cells[1]:>30}   <= {goal}x raw")
    print(f"  shared memory / UDP, quadlet read p50: x{results['shm_vs_udp_read_p50']}")
    print("  (thesis hardware: quadlet read 34.5 us, write 30.2 us, block read base 33.2 us)")
    regime = results["regime"]
    print(
        f"  regime, per call (wake-ups here / the peer's wake-ups / preemptions here), "
        f"rounds settled {results['round_switch_settle_ms']} ms: "
        + ", ".join(
            f"{key} {row['wakeups_per_call']}/{row['peer_wakeups_per_call']}/"
            f"{row['preemptions_per_call']}"
            for key, row in regime.items()
        )
    )
    differ = [key for key, same in results["same_regime_as_raw"].items() if not same]
    if differ:
        print(
            f"  warning: {', '.join(differ)} ran in another regime than the raw ping-pong "
            "(slept or shared a CPU where it polled on its own): those ratios compare regimes"
        )
    cpu = results["raw_udp"].get("cpu_us")
    if cpu:
        print(
            f"  CPU per raw round trip (the floor): this side {cpu['host']} us, "
            f"echo {cpu['node']} us"
        )
    for medium in MEDIA:
        figures = results["media"][medium]
        cpu = figures["quadlet_read"].get("cpu_us")
        if cpu:
            print(
                f"  {medium}: CPU per read (user + kernel) host {cpu['host']} us, node "
                f"{cpu['node']} us (goal, under --idle block: <= 10 and <= 8"
                + ("" if results["idle"] == "block" else f"; this run: {results['idle']}")
                + ")"
            )
        cpu = figures.get("block_read_512_cpu_us")
        if cpu:
            print(
                f"  {medium}: CPU per 512-quadlet block read host {cpu['host']} us, "
                f"node {cpu['node']} us"
            )
        blocks = figures["block_read_mbit_s"]
        print(
            f"  {medium}: 512-quadlet block reads {blocks['sequential']} Mbit/s sequential, "
            f"{blocks['pipelined_4']} four deep, {blocks['pipelined_16']} sixteen deep "
            "(goal >= 1000 four deep; thesis: 360)"
        )
    print("quadlet read vs members (nodes + host), shared memory:")
    scaling = results["media"]["shm"]["members_vs_read"]
    first = next(iter(scaling.values()))["p50_us"]
    for members, row in scaling.items():
        ratio = row["p50_us"] / first
        p50, p99 = row["p50_us"], row["p99_us"]
        print(f"  {members:>3}  p50 {p50:7.1f} us  p99 {p99:8.1f} us  x{ratio:.2f}")
    print("  (goal: 63 members within x1.3 of the smallest bus)")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--quick", action="store_true", help="fewer samples and bus sizes")
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument(
        "--rounds",
        type=int,
        default=20,
        help="interleave raw and bus timings in this many rounds (default 20)",
    )
    parser.add_argument(
        "--idle",
        help="idle strategy of every process of the run: block, spin, adaptive[:us] "
        "(default: FW1394_IDLE, else adaptive)",
    )
    parser.add_argument(
        "--pin",
        action="store_true",
        help="this process on one CPU, the echo and the nodes on the others (steadier ratios)",
    )
    parser.add_argument(
        "--no-scale",
        action="store_true",
        help="skip the bus sizes beyond one node (62 node processes take minutes to start)",
    )
    parser.add_argument(
        "--mechanisms",
        action="store_true",
        help="compare transports (unicast, hub relay, shared memory, multicast with and "
        "without filter)",
    )
    parser.add_argument(
        "--work",
        action="store_true",
        help="CPU of a quadlet read's Python, host and node in one process, no wake-ups "
        "(both media, alternated)",
    )
    parser.add_argument(
        "--doorbells",
        action="store_true",
        help="the shared medium's two doorbells (Unix datagram, POSIX semaphore): "
        "round trip and CPU of a blocked sleeper woken",
    )
    parser.add_argument(
        "--syscalls",
        action="store_true",
        help="CPU per sendto and recv on the bus, and the CPU floor of a quadlet read",
    )
    parser.add_argument(
        "--mac",
        action="store_true",
        help="cost of the keyed MAC: per frame, and quadlet reads keyed vs insecure",
    )
    args = parser.parse_args()
    if args.mac:
        print(json.dumps(mac_cost(args.quick), indent=1))
        return 0
    if args.syscalls:
        print(json.dumps(syscall_costs(5 if args.quick else 40), indent=1))
        return 0
    if args.work:
        print(json.dumps(python_work(5000 if args.quick else 20000), indent=1))
        return 0
    if args.doorbells:
        print(json.dumps(doorbells(2000 if args.quick else 10000), indent=1))
        return 0
    if args.mechanisms:
        print(json.dumps(mechanisms(2000 if args.quick else 5000), indent=1))
        return 0
    if args.idle is not None:
        try:
            parse_idle(args.idle)
        except ValueError as error:
            parser.exit(2, f"bench/bus.py: {error}\n")
        os.environ["FW1394_IDLE"] = args.idle  # the nodes and the echo inherit it
    results = run(args.quick, max(1, args.rounds), args.pin, not args.no_scale)
    if args.json:
        print(json.dumps(results))
    else:
        report(results)
    return 0


if __name__ == "__main__":
    sys.exit(main())
