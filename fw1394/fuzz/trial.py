"""One fuzzing trial: a target, its reference model, a clock, and the oracles.

:meth:`Trial.case` sends one case with whatever follows it (a read-back of
a write, the liveness probe, now and then a sweep of the board's registers),
has the model answer the same packets, and returns the violations. Every
packet sent is kept, with its role and time, in :attr:`Trial.stream`, so a
finding can be replayed and shrunk from the packets that led to it.
"""

from __future__ import annotations

from collections import Counter, deque
from collections.abc import Callable, Iterable
from typing import NamedTuple

from fw1394.engine import Reply
from fw1394.engine.responder import decode_received
from fw1394.fuzz.contract import ack_name, family, silence_reason
from fw1394.fuzz.coverage import outcome
from fw1394.fuzz.judge import Violation, describe, difference, is_silent, visible
from fw1394.fuzz.learned import LearnedRegisters
from fw1394.fuzz.offsets import REGIONAL_FIELDS, OffsetModel, region
from fw1394.fuzz.reference import Certainty, Reference
from fw1394.fuzz.target import Observation, Observed, Target, TargetCrash, Wire
from fw1394.fuzz.tunnel import tlabel_of
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
    Request,
)
from fw1394.packets.fast import decode_sound, encode_packet
from fw1394.packets.nodeid import BROADCAST_PHY, bus_of, phy_of
from fw1394.packets.nodeid import node_id as node_id_of

#: Bytes a read-back of a block write asks for at most.
READBACK_LIMIT = 512
_ACCEPTED = frozenset({AckCode.ack_complete, AckCode.ack_pending})
_STOPPING = frozenset({"liveness", "process"})
#: Why the contract drops a packet without a trace: such a packet must not touch a
#: register either (the ``side-effect`` oracle).
_DROPPED = frozenset(
    {
        "undecodable",
        "not-a-request",
        "other-bus",
        "other-node",
        "unsupported-tcode",
        "bad-header-crc",
        "bad-length",
        "bad-data-crc",
    }
)
#: Register accesses named in a side-effect finding, at most.
_EFFECTS_NAMED = 4
#: Transaction labels are 6 bits; ours count round them.
_TLABEL_MASK = 0x3F  # not a node ID
#: Writes remembered to name in a sweep finding, and named at most.
_WRITES_KEPT = 64
_WRITES_NAMED = 4
#: Learned registers read, taught and read back per batch: a batch's labels must
#: differ (a transport without acks tells replies apart by label alone).
_TAUGHT_PER_BATCH = 8


class Entry(NamedTuple):
    """One packet of the stream: why it was sent, when, and its bytes."""

    role: str  # case, readback, probe, sweep
    time: float
    raw: bytes
    label: str = ""


class _Sent(NamedTuple):
    role: str
    wire: Wire
    label: str


class Trial:
    """Cases against ``target``, judged against ``reference``."""

    def __init__(
        self,
        target: Target,
        reference: Reference,
        model: OffsetModel,
        clock: Callable[[], float],
        *,
        probe_every: int = 1,
        state_every: int = 64,
        history: int = 512,
        source_id: int = 0xFFFE,
    ) -> None:
        self.target = target
        self.reference = reference
        self.model = model
        self.clock = clock
        self.probe_every = max(1, probe_every)
        self.state_every = state_every
        self.source_id = source_id
        self.stream: deque[Entry] = deque(maxlen=history)
        #: Checks made per oracle (for the coverage report).
        self.checks: Counter[str] = Counter()
        #: The last batch ended the node (liveness or process): recover before going on.
        self.broken = False
        #: The last case as sent (for the campaign's coverage counts).
        self.last_wire = Wire(b"", None, True)
        #: What the node gave the last case: silence, ack_complete, ... (for coverage).
        self.last_outcome = "silence"
        self._tlabel = 0
        self._avoid = -1
        self._cases = 0
        self._write_status = "accepted"
        self._sweep_ok: dict[int, bool] = {}
        self._probes: dict[tuple[int, int], Wire] = {}
        self._node_bits_only = reference.policy.ignore_bus_id
        # Offsets of the writes and locks sent as cases (numbered), and the number of
        # the last one before each swept register was read: a register that changes
        # names the writes since its last read.
        self._writes: deque[tuple[int, int]] = deque(maxlen=_WRITES_KEPT)
        self._write_count = 0
        self._read_after: dict[int, int] = {}
        self._changed: set[int] = set()
        #: Without a model of the board, the data oracle that learns from its answers.
        self.learned = LearnedRegisters(model.quadlet_index) if reference.kind is None else None
        self._swept_after = 0  # the write count when the last sweep began
        self._other = 0  # the last other node read, as an offset from the target's
        # Registers the node writes by itself (rtl: port maps may name them): what a
        # read of them returns is the node's business, not the model's.
        owned = getattr(target, "owned", None)
        self._owned: frozenset[int] = owned() if owned is not None else frozenset()

    # -- driving ------------------------------------------------------------------------
    def case(self, raw: bytes, label: str = "") -> list[Violation]:
        """Send one case and what follows it; the violations found."""
        self._cases += 1
        wire = self.last_wire = wire_of(raw)
        batch = [_Sent("case", wire, label)]
        # Our own packets never share the case's label: a transport without acks
        # (Eth1394) tells replies apart by label alone.
        self._avoid = _label_in(wire)
        readback = self._readback(wire.packet)
        if readback is not None:
            batch.append(_Sent("readback", readback, ""))
        if self.target.needs_fence or self._cases % self.probe_every == 0:
            batch.append(_Sent("probe", self._probe(), ""))
        violations = self._run(batch)
        if self.state_every and self._cases % self.state_every == 0 and not self.broken:
            violations += self.sweep()
        return violations

    def sweep(self) -> list[Violation]:
        """Read every register of the sweep list and compare with the model; read each
        learned register, and teach it a fresh value (:mod:`fw1394.fuzz.learned`)."""
        batch = [_Sent("sweep", self._read(offset), "") for offset in self.model.sweep]
        if batch and self.target.needs_fence:
            batch.append(_Sent("probe", self._probe(), ""))
        # Changes seen by the next sweep name the writes from here on, markers included.
        self._swept_after = self._write_count
        found = self._run(batch)
        if self.learned is None or self.broken:
            return found
        # One other node ID per sweep, all 62 in turn: a node answering for another
        # is a silence finding like any case's.
        found += self._run([_Sent("case", self._read_as(self._next_other(), self.model.probe), "")])
        registers = self.learned.registers
        for start in range(0, len(registers), _TAUGHT_PER_BATCH):
            if self.broken:
                break
            batch = []
            for register in registers[start : start + _TAUGHT_PER_BATCH]:
                marker = self.learned.marker(register)
                batch += [
                    _Sent("sweep", self._read(register), ""),
                    _Sent("learn", self._write(register, marker), ""),
                    _Sent("readback", self._read(register), ""),
                ]
            found += self._run(batch)
        return found

    def replay(self, entries: Iterable[Entry], *, keep_times: bool = True) -> list[Violation]:
        """Send recorded entries again, one batch each, judged by their roles.

        ``keep_times``: at the recorded times (a fresh in-process node); otherwise
        on the trial's clock (a remote node keeps its own time anyway).
        """
        found: list[Violation] = []
        for entry in entries:
            wire = wire_of(entry.raw)
            self._avoid = _label_in(wire)
            batch = [_Sent(entry.role, wire, entry.label)]
            found += self._run(batch, entry.time if keep_times else None)
            if self.broken:
                break
        return found

    def restart(self, reference: Reference) -> None:
        """A fresh node and model (after a crash or a wedge); the stream starts over."""
        self.target.restart()
        self.reference = reference
        self.stream.clear()
        self._sweep_ok.clear()
        self._changed.clear()
        if self.learned is not None:
            self.learned.reset()
        self.broken = False

    # -- one batch ----------------------------------------------------------------------
    def _run(self, batch: list[_Sent], now: float | None = None) -> list[Violation]:
        now = self.clock() if now is None else now
        expect = self.reference.expect
        expected = [
            expect(sent.wire.packet, sent.wire.damaged, now, raw=sent.wire.raw) for sent in batch
        ]
        if self._owned:
            expected = [
                (reply, Certainty.header) if self._reads_owned(sent.wire.packet) else (reply, c)
                for sent, (reply, c) in zip(batch, expected, strict=True)
            ]
        if self.target.needs_fence and batch:
            visibility = self.target.visibility
            if is_silent(visible(expected[-1][0], visibility)):
                fence = _Sent("probe", self._probe(), "")
                batch.append(fence)
                expected.append(expect(fence.wire.packet, False, now, raw=fence.wire.raw))
        stream = self.stream
        for sent in batch:
            stream.append(Entry(sent.role, now, sent.wire.raw, sent.label))
        try:
            observed = self.target.exchange([sent.wire for sent in batch], now)
        except TargetCrash as crash:
            self.broken = True
            self.checks["process"] += 1
            signature = f"crash:{str(crash).split(':')[0]}"
            return [Violation("process", signature, "a reply", str(crash))]
        found: list[Violation] = []
        for sent, (reply, certainty), seen in zip(batch, expected, observed, strict=True):
            violation = self._judge(sent, reply, certainty, seen)
            if violation is not None:
                found.append(violation)
                found += self._hidden_behind(violation, sent, reply, certainty, seen)
        if any(sent.role == "probe" for sent in batch):
            found += self._process_check()
        found += self._interface_check()
        found += self._effect_check(batch, [reply for reply, _ in expected])
        if any(v.oracle in _STOPPING for v in found):
            self.broken = True
        return found

    def _process_check(self) -> list[Violation]:
        self.checks["process"] += 1
        problem = self.target.problem()
        if problem is None:
            return []
        return [Violation("process", problem.split(":")[0], "the node's process alive", problem)]

    def _interface_check(self) -> list[Violation]:
        # Targets that watch the node's pins (rtl:) report the interface rules it broke.
        take = getattr(self.target, "interface_violations", None)
        if take is None:
            return []
        self.checks["interface"] += 1
        return [
            Violation(
                "interface", line.partition(": ")[0], "the PHY-link interface rules kept", line
            )
            for line in take()
        ]

    def _reads_owned(self, packet: AsyncPacket | None) -> bool:
        if not isinstance(packet, (QuadletReadRequest, BlockReadRequest)):
            return False
        quadlets = 1
        if isinstance(packet, BlockReadRequest):
            quadlets = max(1, (packet.data_length + 3) // 4)
        first = packet.offset & 0xFFFF if self.model.quadlet_index else packet.offset >> 2
        return any(first <= index < first + quadlets for index in self._owned)

    def _effect_check(self, batch: list[_Sent], expected: list[Reply]) -> list[Violation]:
        # Targets that watch the design's register strobes (rtl:) report the accesses
        # each packet caused: one the contract drops must cause none.
        take = getattr(self.target, "side_effects", None)
        if take is None:
            return []
        found = []
        node_id, policy = self.reference.node_id, self.reference.policy
        for sent, reply, effects in zip(batch, expected, take(), strict=False):
            if not is_silent(reply):
                continue
            packet = sent.wire.packet
            reason = silence_reason(packet, sent.wire.damaged, node_id, policy)
            if reason not in _DROPPED:
                continue
            self.checks["side-effect"] += 1
            if not effects:
                continue
            what = "write" if any(kind == "write" for kind, _, _ in effects) else "read"
            accesses = ", ".join(_access(*effect) for effect in effects[:_EFFECTS_NAMED])
            if len(effects) > _EFFECTS_NAMED:
                accesses += f" and {len(effects) - _EFFECTS_NAMED} more"
            found.append(
                Violation(
                    "side-effect",
                    f"{reason}:{family(packet)}:{what}",
                    f"no register access ({reason}: dropped)",
                    accesses,
                )
            )
        return found

    # -- oracles ------------------------------------------------------------------------
    def _judge(
        self, sent: _Sent, reply: Reply, certainty: Certainty, seen: Observed
    ) -> Violation | None:
        if sent.role == "case":
            return self._judge_case(sent.wire, reply, certainty, seen)
        if self.learned is not None:
            learned = self._judge_learned(sent, seen)
            if learned is not None:
                return learned
        shown = visible(reply, self.target.visibility)
        if not is_silent(shown):
            self.checks["liveness"] += 1
            if is_silent(seen):
                return Violation("liveness", "valid-read-unanswered", describe(shown), "silence")
        oracle = "reply" if sent.role == "probe" else "state"
        self.checks[oracle] += 1
        field = difference(shown, seen, certainty, self.target.visibility, **self._options())
        if sent.role == "sweep":
            return self._judge_sweep(sent.wire, field, shown, seen)
        if field is None:
            return None
        if sent.role == "probe":
            where = self._region(sent.wire.packet, field, shown, seen)
            field = _regional(field) if where else field
            return Violation("reply", f"read{where}:{field}", describe(shown), describe(seen))
        where = _offset_text(sent.wire.packet)
        # A write the node should have dropped or refused that changed a register is
        # a defect of packet handling, whichever register it hit: one finding.
        register = ""
        if self._write_status == "accepted":
            register = self._region(sent.wire.packet, field, shown, seen)
        return Violation(
            "state",
            f"{self._write_status}-write{register}:{_regional(field) if register else field}",
            f"read-back{where}: {describe(shown)}",
            f"read-back{where}: {describe(seen)}",
        )

    def _judge_learned(self, sent: _Sent, seen: Observed) -> Violation | None:
        learned, packet = self.learned, sent.wire.packet
        if learned is None or packet is None:
            return None
        offset = getattr(packet, "offset", 0)
        if sent.role == "learn" and isinstance(packet, QuadletWriteRequest):
            learned.taught(offset, packet.quadlet_data)
            # A marker is a write like any other: one may change another register.
            self._write_count += 1
            self._writes.append((self._write_count, offset))
            return None
        if sent.role == "readback":
            self.checks["state"] += 1
            return learned.read_back(offset, seen.response)
        if sent.role == "sweep":
            since = [o for n, o in reversed(self._writes) if n > self._swept_after]
            return learned.swept(offset, seen.response, _after_writes(since))
        return None

    def _judge_case(
        self, wire: Wire, reply: Reply, certainty: Certainty, seen: Observed
    ) -> Violation | None:
        packet = wire.packet
        kind = family(packet)
        self.last_outcome = outcome(seen)
        if kind in ("write", "lock"):
            self._write_status = _status(reply, packet, wire.damaged, self.reference)
            if self.learned is not None and packet is not None:
                self.learned.wrote(packet, accepted=self._write_status == "accepted")
            # Every write names itself in a learned register's change (one to another
            # node too: a node may take it for its own).
            if self._write_status == "accepted" or self.learned is not None:
                self._write_count += 1
                self._writes.append((self._write_count, getattr(packet, "offset", 0)))
        if is_silent(reply):
            self.checks["silence"] += 1
            if is_silent(seen):
                return None
            node_id, policy = self.reference.node_id, self.reference.policy
            reason = silence_reason(packet, wire.damaged, node_id, policy)
            answer = ack_name(seen.ack) if seen.ack is not None else "response"
            return Violation("silence", f"{reason}:{kind}:{answer}", "silence", describe(seen))
        self.checks["reply"] += 1
        shown = visible(reply, self.target.visibility)
        field = difference(shown, seen, certainty, self.target.visibility, **self._options())
        if field is None:
            return None
        where = self._region(packet, field, shown, seen)
        if where:
            field = _regional(field)
        if field == "ack":
            field += f":{ack_name(shown.ack)}->{ack_name(seen.ack)}"
        return Violation("reply", f"{kind}{where}:{field}", describe(shown), describe(seen))

    def _hidden_behind(
        self, violation: Violation, sent: _Sent, reply: Reply, certainty: Certainty, seen: Observed
    ) -> list[Violation]:
        # A tenure mismatch is found before the response's fields are compared: a
        # wrong response in the wrong tenure is two root causes, two findings.
        if sent.role != "case" or not violation.signature.endswith(":tenure"):
            return []
        shown = visible(reply, self.target.visibility)
        retimed = Observation(seen.ack, seen.response, shown.concatenated)
        field = difference(shown, retimed, certainty, self.target.visibility, **self._options())
        if field is None:
            return []
        where = self._region(sent.wire.packet, field, shown, retimed)
        kind = family(sent.wire.packet) + where
        field = _regional(field) if where else field
        return [Violation("reply", f"{kind}:{field}", describe(shown), describe(seen))]

    def _judge_sweep(
        self, wire: Wire, field: str | None, shown: Reply, seen: Observed
    ) -> Violation | None:
        offset = getattr(wire.packet, "offset", 0)
        was_ok = self._sweep_ok.get(offset)
        self._sweep_ok[offset] = field is None
        since = self._read_after.get(offset, 0)
        self._read_after[offset] = self._write_count
        if field is None:
            self._changed.discard(offset)
            return None
        if offset in self._changed:
            return None  # the change was reported when it happened
        expected, observed = (f"register {offset:#x}: {describe(r)}" for r in (shown, seen))
        register = self._region(wire.packet, field, shown, seen)
        where = f"{register}:{_regional(field) if register else field}"
        if was_ok:
            self._changed.add(offset)
            # It read right last time: something since then changed it, most likely
            # a write elsewhere (a write to the register itself has its read-back).
            observed += _after_writes([o for n, o in reversed(self._writes) if n > since])
            return Violation("state", f"sweep-changed{where}", expected, observed)
        return Violation("reply", f"read{where}", expected, observed)

    def _options(self) -> dict[str, bool]:
        return {"node_bits_only": self._node_bits_only}

    def _region(
        self,
        packet: AsyncPacket | None,
        field: str,
        reply: Reply | None = None,
        seen: Observed | None = None,
    ) -> str:
        """``@REGISTER`` for a mismatch in what a register does (one finding per
        register and kind of mismatch, not one for every register the model gets
        wrong), ``""`` for one in the packet itself or without a model. The
        register of a block is the first one whose data differ."""
        if field not in REGIONAL_FIELDS:
            return ""
        offset = getattr(packet, "offset", None)
        if offset is not None and reply is not None and seen is not None:
            offset += self._first_difference(reply.response, seen.response)
        where = region(self.reference.kind, offset)
        return f"@{where}" if where else ""

    def _first_difference(self, want: object, got: object) -> int:
        """How far into a block the first differing quadlet lies, in the target's units."""
        a, b = _payload(want), _payload(got)
        if a is None or b is None:
            return 0
        for start in range(0, min(len(a), len(b)), 4):
            if a[start : start + 4] != b[start : start + 4]:
                return start // 4 if self.model.quadlet_index else start
        return 0

    # -- packets of our own ----------------------------------------------------------------
    def _next_tlabel(self) -> int:
        self._tlabel = (self._tlabel + 1) & _TLABEL_MASK
        if self._tlabel == self._avoid:
            self._tlabel = (self._tlabel + 1) & _TLABEL_MASK
        return self._tlabel

    def _read(self, offset: int, length: int | None = None, *, tlabel: int | None = None) -> Wire:
        node, source = self.reference.node_id, self.source_id
        tlabel = self._next_tlabel() if tlabel is None else tlabel
        packet: AsyncPacket
        if length is None:
            packet = QuadletReadRequest(
                destination_id=node, tlabel=tlabel, source_id=source, offset=offset
            )
        else:
            packet = BlockReadRequest(
                destination_id=node,
                tlabel=tlabel,
                source_id=source,
                offset=offset,
                data_length=length,
            )
        return Wire(encode_packet(packet), packet, False)

    def _next_other(self) -> int:
        """The next node ID but the target's (rotating over the 62 others)."""
        node = self.reference.node_id
        self._other = self._other % (BROADCAST_PHY - 1) + 1
        return node_id_of((phy_of(node) + self._other) % BROADCAST_PHY, bus_of(node))

    def _read_as(self, destination: int, offset: int) -> Wire:
        packet = QuadletReadRequest(
            destination_id=destination,
            tlabel=self._next_tlabel(),
            source_id=self.source_id,
            offset=offset,
        )
        return Wire(encode_packet(packet), packet, False)

    def _write(self, offset: int, value: int) -> Wire:
        packet = QuadletWriteRequest(
            destination_id=self.reference.node_id,
            tlabel=self._next_tlabel(),
            source_id=self.source_id,
            offset=offset,
            quadlet_data=value,
        )
        return Wire(encode_packet(packet), packet, False)

    def _probe(self) -> Wire:
        # The same few packets over and over: made once per label.
        key = (self.reference.node_id, self._next_tlabel())
        wire = self._probes.get(key)
        if wire is None:
            wire = self._probes[key] = self._read(self.model.probe, tlabel=key[1])
        return wire

    def _readback(self, packet: AsyncPacket | None) -> Wire | None:
        if family(packet) not in ("write", "lock"):
            return None
        assert isinstance(packet, Request)
        if isinstance(packet, BlockWriteRequest):
            length = min(max(len(packet.data), 4), READBACK_LIMIT) & ~3
            return self._read(packet.offset, length)
        return self._read(packet.offset)


def _label_in(wire: Wire) -> int:
    """The label a node could read in the case's bytes (even when it decodes no packet)."""
    label = tlabel_of(wire.raw)
    return -1 if label is None else label


def wire_of(raw: bytes) -> Wire:
    packet, damaged = decode_received(raw)
    return Wire(raw, packet, damaged)


def _status(reply: Reply, packet: AsyncPacket | None, damaged: bool, reference: Reference) -> str:
    """What the contract did with a write: accepted, refused (error ack) or dropped."""
    if reply.ack in _ACCEPTED:
        return "accepted"
    if reply.ack is not None:
        return "refused"
    reason = silence_reason(packet, damaged, reference.node_id, reference.policy)
    return "accepted" if reason == "broadcast" else "dropped"


def _after_writes(offsets: list[int]) -> str:
    """Which writes came between two reads of a register that changed (latest first)."""
    if not offsets:
        return ""
    distinct = list(dict.fromkeys(offsets))
    shown = ", ".join(f"{o:#x}" for o in distinct[:_WRITES_NAMED])
    more = f" and {len(distinct) - _WRITES_NAMED} more" if len(distinct) > _WRITES_NAMED else ""
    return f", changed after accepted writes to {shown}{more}"


def _regional(field: str) -> str:
    """A data mismatch is one, whether a quadlet or a block showed it."""
    return "data" if field == "quadlet_data" else field


def _payload(response: object) -> bytes | None:
    """The data a read response carries (decoded first if raw), else None."""
    if isinstance(response, bytes):
        response = decode_sound(response)
    quadlet = getattr(response, "quadlet_data", None)
    if quadlet is not None:
        return int(quadlet).to_bytes(4, "big")
    data = getattr(response, "data", None)
    return bytes(data) if isinstance(data, bytes | bytearray) else None


def _offset_text(packet: AsyncPacket | None) -> str:
    offset = getattr(packet, "offset", None)
    return "" if offset is None else f" at {offset:#x}"


def _access(kind: str, index: int, data: int | None) -> str:
    return f"register {index:#x} read" if data is None else f"register {index:#x} <- {data:#010x}"
