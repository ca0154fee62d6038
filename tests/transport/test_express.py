"""The one-pass blocking calls end every transaction as the general path does.

Two hosts run the same script against a scripted station: one through
:class:`~fw1394.host.bus_port.BusPort` (its express path), one through the
general start-and-wait path BusPort used before. The station answers each
request from a real responder (thesis, IEEE 1394 or JHU policy, so concatenated,
split and unified answers), and the script spoils some answers: busy acks,
offsets the node refuses, a stray frame first (another label, a copy of the
previous answer, a PHY packet), a quiet poll before the answer, no answer at
all, a bus reset. Time is a fake clock that moves only when the station waits.
Both hosts must return the same values or raise the same errors, send the same
frames, and leave the same requester and host state behind; and a clean answer
must end without the general loop ever running.
"""

from __future__ import annotations

import copy
import math
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest
from bus_support import bus_name, wait_hosts_dropped, wait_until_gone
from hypothesis import given, settings
from hypothesis import strategies as st

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Responder, TransactionEvent, TransactionFailed
from fw1394.engine.policy import POLICIES
from fw1394.host.bus_port import BusPort
from fw1394.packets import AckCode
from fw1394.packets.ack import ACK_BYTES
from fw1394.packets.frame import ACK_FRAME_FORMAT, FRAME_TRAILER_SIZE
from fw1394.packets.nodeid import node_id
from fw1394.transport import bus_host, express, link
from fw1394.transport.bus_host import BusError, TransactionError
from fw1394.transport.link import ResponderLink
from fw1394.transport.sansio.config import BusConfig
from fw1394.transport.sansio.membership import BusReset, Timing
from fw1394.transport.sansio.wire import FrameHeader, FrameKind, MemberInfo
from fw1394.transport.supervision.launch import LaunchedBus

NODE, HOST = 0, 1
MEMORY = 64
#: A quiet poll: short, so that timers fire where they are due, to a fraction of a ms.
POLL = 0.0003
TIMING = Timing(heartbeat=0.1, lease=1.0)
COMPLETE = ACK_BYTES[AckCode.ack_complete]
MEMBERS = (MemberInfo(1, 1), MemberInfo(2, 2, contender=True, host=True))


class Clock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


@dataclass
class Answer:
    """How the node answers the next request (its retries it answers plainly)."""

    policy: str = "thesis"
    busy: int = 0
    #: A frame before the answer: an ack of another label, a copy of the last frame
    #: the node sent, a PHY packet, the answer as a node of the last generation or
    #: another node sends it.
    stray: str = ""  # "label", "copy", "phy", "stale", "elsewhere"
    quiet: int = 0  # quiet polls before the answer
    silent: bool = False  # no answer at all
    reset: bool = False  # a bus reset instead of an answer

    @property
    def clean(self) -> bool:
        return self == Answer()


class ScriptedStation:
    """What a host needs of a station; a node on a memory space answers its requests."""

    def __init__(self, clock: Clock) -> None:
        self.clock = clock
        self.faults = None
        self.trailer_size = 0
        self.wake_by = math.inf
        self.membership = SimpleNamespace(
            ready=True, generation=1, phy_id=HOST, members=MEMBERS, timing=TIMING, role="member"
        )
        self.member_id = 2
        self.space = MemorySpace(MEMORY)
        self.expect(Answer())
        self.inbox: deque[tuple[FrameHeader, bytes] | None] = deque()
        self.log: list[tuple[Any, ...]] = []
        self.pending = [BusReset(self.generation, HOST, MEMBERS, 0)]
        self.sequence = 0
        self.last_answer: tuple[FrameHeader, bytes] | None = None
        self.serviced_at = clock.now

    @property
    def generation(self) -> int:
        return int(self.membership.generation)

    @property
    def phy_id(self) -> int:
        return HOST

    def expect(self, answer: Answer) -> None:
        """The node's answers to the requests of the next call."""
        self.answer, self.first = answer, True
        responder = Responder(node_id(NODE), self.space, POLICIES[answer.policy])
        responder.inject_busy(answer.busy)
        self.node = ResponderLink(responder, self._deliver)

    def send(self, kind: int, destination: int, payload: bytes, speed: int = 0) -> int:
        self.sequence += 1
        self.log.append(("sent", kind, destination, bytes(payload), self.generation))
        if kind == FrameKind.async_packet and destination == NODE:
            self._answer(payload)
        return self.sequence

    def _answer(self, request: bytes) -> None:
        answer, first = self.answer, self.first
        self.first = False
        if first and answer.silent:
            return
        if first and answer.reset:
            self._reset()
            self.inbox.append(None)  # the reset frame: nothing for the owner
            return
        if first:
            self.inbox.extend([None] * answer.quiet)
            if answer.stray == "phy":
                self._deliver(FrameKind.phy_packet, NODE, bytes(8))
            elif answer.stray == "copy" and self.last_answer is not None:
                self.inbox.append(self.last_answer)
            elif answer.stray == "label":
                label = (request[2] >> 2) ^ 1
                self._deliver(FrameKind.ack, NODE, ACK_FRAME_FORMAT.pack(COMPLETE, label, 0, 1))
        header = FrameHeader(FrameKind.async_packet, 1, 1, self.generation, HOST, NODE)
        before = len(self.inbox)
        self.node.take(header._replace(sequence=self.sequence), request, self.clock.now)
        if first and answer.stray in ("stale", "elsewhere") and len(self.inbox) > before:
            # The same answer from a node still in the generation before, or from
            # another node: neither answers this request.
            real, payload = self.inbox[before]  # type: ignore[misc]
            if answer.stray == "stale":
                fake = real._replace(generation=real.generation - 1)
            else:
                fake = real._replace(sender_phy=NODE + 3)
            self.inbox.insert(before, (fake, payload))

    def _deliver(self, kind: int, destination: int, payload: bytes) -> None:
        header = FrameHeader(kind, 1, 1, self.generation, NODE, HOST, sequence=len(self.log))
        self.inbox.append((header, payload))
        self.last_answer = header, payload

    def _reset(self) -> None:
        self.membership.generation += 1
        self.pending.append(BusReset(self.generation, HOST, MEMBERS, 2))

    # -- receiving --------------------------------------------------------------------
    def receive(self) -> tuple[FrameHeader, bytes] | None:
        frame = self.inbox.popleft() if self.inbox else None
        self.clock.now += 1e-5 if frame is not None else POLL
        return frame

    def catch_up(self) -> Iterator[tuple[FrameHeader, bytes]]:
        self.log.append(("catch up",))
        while self.inbox:
            frame = self.inbox.popleft()
            if frame is not None:
                yield frame

    def changes(self) -> list[BusReset]:
        out, self.pending = self.pending, []
        return out

    def next_deadline(self) -> float:
        return self.serviced_at + TIMING.heartbeat

    def service(self, now: float | None = None) -> None:
        self.serviced_at = self.clock.now if now is None else now

    def rejoin(self) -> None:
        self.log.append(("rejoin",))
        self._reset()

    def close(self) -> None:
        pass


# -- the two hosts -----------------------------------------------------------------------
Op = tuple[str, int, int, Any]


def _general(port: BusPort, op: Op) -> object:
    """What BusPort's calls did before the express path: start, wait, judge."""
    kind, node, offset, argument = op
    start = getattr(port, f"start_{kind}")
    event: TransactionEvent = port.wait(
        start(node, offset) if kind == "read_quadlet" else start(node, offset, argument)
    )
    if isinstance(event, TransactionFailed):
        raise TransactionError(event)
    if kind == "read_quadlet":
        return int.from_bytes(event.data)  # type: ignore[attr-defined]
    return event.data if kind == "read_block" else None  # type: ignore[attr-defined]


def _express(port: BusPort, op: Op) -> object:
    kind, node, offset, argument = op
    call = getattr(port, kind)
    return call(node, offset) if kind == "read_quadlet" else call(node, offset, argument)


def _state(port: BusPort) -> tuple[Any, ...]:
    """Everything the requester and the host keep between calls."""
    r = port.requester
    transactions = [
        (t.tid, t.key, t.label, t.state, t.deadline, t.queued, t.busy, t.request, t.length)
        for t in r._transactions.values()
    ]
    labels = r._labels
    return (
        r._next_tid,
        labels._held,
        labels._next,
        labels._until,
        r._ended,
        r._timers,
        transactions,
        {key: t.tid for key, t in r._by_label.items()},
        r._outbox,
        r._events,
        r._waiting,
        r.generation,
        r.node_id,
        port._finished,
        port._other_events,
        port._served_at,
        port._timers_due,
        port.link.due,
        port.resets,
    )


def _run(script: list[Any], general: bool) -> tuple[list[Any], list[Any], list[int]]:
    """Outcomes and states after each step, the frames sent, general-loop turns per call."""
    clock = Clock()
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(bus_host, "time", SimpleNamespace(monotonic=clock))
        patch.setattr(link, "_clock", clock)
        patch.setattr(express, "_clock", clock)
        station = ScriptedStation(clock)
        patch.setattr(bus_host, "Station", lambda *args, **kwargs: station)
        port = BusPort(BusConfig("scripted"), ack_timeout=0.02, split_timeout=0.05)
        port.link.apply_changes()  # the self-ID phase the station says is complete
        turns = [0]
        pump = port._pump

        def counted() -> None:
            turns[0] += 1
            pump()

        patch.setattr(port, "_pump", counted)
        outcomes: list[Any] = []
        per_call: list[int] = []
        for step in script:
            if step[0] == "pause":
                clock.now += step[1]
                continue
            op, answer = step
            station.expect(answer)
            turns[0] = 0
            try:
                outcome: Any = ("ok", (_general if general else _express)(port, op))
            except (TransactionError, BusError, ValueError) as error:
                outcome = ("error", type(error).__name__, str(error))
            per_call.append(turns[0])
            outcomes.append((outcome, copy.deepcopy(_state(port)), clock.now))
        return outcomes, station.log, per_call


def _plain(op: Op) -> bool:
    kind, node, offset, argument = op
    return node in (NODE, node_id(NODE)) and 0 <= offset <= MEMORY - 4 - (
        len(argument) if kind == "write_block" else argument if kind == "read_block" else 0
    )


policies = st.sampled_from(sorted(POLICIES))
strays = st.sampled_from(["label", "copy", "phy", "stale", "elsewhere"])
answers = st.one_of(
    st.just(Answer()),
    # One thing unusual at a time, and then several.
    st.builds(Answer, policy=policies),
    st.builds(Answer, busy=st.integers(1, 4)),
    st.builds(Answer, stray=strays),
    st.builds(Answer, quiet=st.integers(1, 2)),
    st.just(Answer(silent=True)),
    st.just(Answer(reset=True)),
    st.builds(
        Answer,
        policy=policies,
        busy=st.integers(0, 4),
        stray=strays | st.just(""),
        quiet=st.integers(0, 2),
        silent=st.booleans(),
        reset=st.booleans(),
    ),
)
offsets = st.one_of(
    st.integers(0, MEMORY // 4 - 1).map(lambda q: 4 * q),
    st.sampled_from([MEMORY + 4, 1 << 40, -4, 1 << 48]),
)
nodes = st.sampled_from([NODE, NODE, NODE, node_id(NODE), 5, 63])
ops = st.one_of(
    st.tuples(st.just("read_quadlet"), nodes, offsets, st.none()),
    st.tuples(st.just("read_block"), nodes, offsets, st.integers(0, 16)),
    st.tuples(st.just("write_quadlet"), nodes, offsets, st.integers(0, (1 << 32) - 1)),
    st.tuples(st.just("write_block"), nodes, offsets, st.binary(max_size=16)),
)
steps = st.one_of(
    st.tuples(ops, answers),
    st.tuples(ops, answers),
    st.tuples(st.just("pause"), st.sampled_from([0.001, 0.15, 1.5])),
)


def _same_on_both_paths(script: list[Any]) -> None:
    fast, fast_frames, fast_turns = _run(script, general=False)
    reference, reference_frames, _ = _run(script, general=True)
    for number, (mine, theirs) in enumerate(zip(fast, reference, strict=True)):
        assert mine == theirs, f"call {number}"
    assert fast_frames == reference_frames
    calls = [step for step in script if step[0] != "pause"]
    for (op, answer), turns in zip(calls, fast_turns, strict=True):
        if answer.clean and _plain(op):
            assert turns == 0, f"{op} took the general loop"


@settings(max_examples=300, deadline=None)
@given(st.lists(steps, max_size=12))
def test_express_calls_end_as_the_general_path(script: list[Any]) -> None:
    _same_on_both_paths(script)


PLAIN: list[Op] = [
    ("read_quadlet", NODE, 8, None),
    ("read_block", NODE, 4, 12),
    ("write_quadlet", NODE, 8, 0x01020304),
    ("write_block", NODE, 4, b"0123456789"),
]
UNUSUAL = [
    *(Answer(policy=policy) for policy in sorted(POLICIES) if policy != "thesis"),
    Answer(busy=1),
    Answer(busy=4),
    *(Answer(stray=stray) for stray in ("label", "copy", "phy", "stale", "elsewhere")),
    Answer(quiet=1),
    Answer(silent=True),
    Answer(reset=True),
]


@pytest.mark.parametrize("answer", UNUSUAL, ids=repr)
@pytest.mark.parametrize("op", PLAIN, ids=lambda op: op[0])
def test_each_unusual_answer_between_clean_ones(op: Op, answer: Answer) -> None:
    # What the unusual answer leaves behind (a stray frame, a held label) must not
    # let the next call end differently either.
    clean = Answer()
    _same_on_both_paths([(op, clean), (op, answer), (op, clean), (PLAIN[0], clean)])


def test_a_call_after_a_pause_longer_than_the_lease_rejoins_before_it_sends() -> None:
    # A host that did not run for longer than its lease has been dropped from the
    # bus: its next call must take in what the bus said and join again before the
    # request goes out, or the request leaves in a generation that is over.
    write, read = PLAIN[2], PLAIN[0]
    script = [(write, Answer()), ("pause", 1.5), (read, Answer())]
    _same_on_both_paths(script)
    outcomes, log, turns = _run(script, general=False)
    assert outcomes[1][0] == ("ok", 0x01020304)
    assert turns == [0, 0], "the express path took both calls"
    rejoined = log.index(("rejoin",))
    assert log[rejoined - 1] == ("catch up",)
    request = next(entry for entry in log[rejoined:] if entry[0] == "sent")
    assert request[4] == 2, "the request after the pause went out in the new generation"


@pytest.mark.process
@pytest.mark.parametrize("key", [None, bytes(range(32))], ids=["insecure", "keyed"])
def test_blocking_calls_on_a_real_bus_after_the_host_was_away(
    tmp_path: Path, key: bytes | None
) -> None:
    # A real node, and a host that does not run for 2.5 leases (as a stopped or
    # starved process does not): the coordinator drops it meanwhile. On a keyed
    # bus every frame carries a trailer the station adds and checks.
    config = BusConfig(bus_name("express"))
    timing = ("--heartbeat", "0.1", "--lease", "1.0")
    with LaunchedBus(config, 1, root=tmp_path, node_arguments=timing, key=key) as bus:
        bus.wait_members()
        with BusPort(bus.member_config, timing=Timing(heartbeat=0.1, lease=1.0)) as port:
            assert port.station.trailer_size == (0 if key is None else FRAME_TRAILER_SIZE)
            port.wait_ready()
            port.write_quadlet(0, 8, 0xCAFE)
            port.write_block(0, 16, b"express!")
            resets = len(port.resets)
            # The host does not run until the coordinator has dropped it.
            wait_hosts_dropped(bus.member_config)
            assert port.read_quadlet(0, 8) == 0xCAFE
            assert port.read_block(0, 16, 8) == b"express!"
            assert len(port.resets) > resets, "the host must have rejoined the bus"
    assert wait_until_gone(config.name) == []
