"""Plausible bus traffic for tests and benchmarks: a host polling FPGA boards.

The pattern follows the JHU controllers: every control cycle the host reads
each board's real-time block and writes its commands. Around it the things
a dissector must notice happen now and then: busy acks and retries, bus
resets with self-IDs and configuration-ROM reads, lost responses, corrupted
CRCs and unsolicited responses. Encoded packets are cached, so a million
records take seconds, not minutes.
"""

from __future__ import annotations

import random
from collections.abc import Iterator
from dataclasses import dataclass

from fw1394.capture.analysis import rom_decode as rom
from fw1394.capture.analysis.csr import CONFIG_ROM, CSR_BASE
from fw1394.capture.formats.record import BusRecord, RecordType
from fw1394.packets import (
    AckCode,
    BlockReadRequest,
    BlockReadResponse,
    BlockWriteRequest,
    QuadletReadRequest,
    QuadletReadResponse,
    SelfIdPacket,
    Speed,
    encode,
)
from fw1394.packets.ack import ack_byte
from fw1394.packets.nodeid import LOCAL_BASE

RT_BLOCK_BYTES = 128
COMMAND_BYTES = 24


@dataclass(frozen=True)
class Scenario:
    boards: int = 4
    cycle_ns: int = 250_000
    busy_every: int = 997  # cycles between busy acks
    reset_every: int = 40_000  # cycles between bus resets
    lost_every: int = 4_999  # cycles between lost responses
    corrupt_every: int = 7_919  # cycles between corrupted responses
    unsolicited_every: int = 15_013
    separate_acks: bool = False  # acks as their own records, as a snoop shows them
    seed: int = 1394


class _Bus:
    def __init__(self, scenario: Scenario) -> None:
        self.s = scenario
        self.random = random.Random(scenario.seed)
        self.host = scenario.boards  # the host is the root, the highest physical ID
        self.now = 0
        self.generation = 1
        self.tl = 0
        self.cache: dict[tuple[object, ...], bytes] = {}
        self.roms = [
            rom.build_rom(0x00A0B0, 0x1394 + b, 0x00A0B0_0000000000 + b, "JHU LCSR", f"QLA{b}")
            for b in range(scenario.boards)
        ]
        self.records: list[BusRecord] = []

    def label(self) -> int:
        self.tl = (self.tl + 1) % 64
        return self.tl

    def packet(self, key: tuple[object, ...], build: object) -> bytes:
        raw = self.cache.get(key)
        if raw is None:
            raw = encode(build)  # type: ignore[arg-type]
            if len(self.cache) < 50_000:
                self.cache[key] = raw
        return raw

    def emit(self, data: bytes, sender: int, ack: int | None, gap_ns: int) -> None:
        """A host packet ``gap_ns`` after the previous one."""
        self.now += gap_ns
        self.at(self.now, data, sender, ack)

    def at(self, when: int, data: bytes, sender: int, ack: int | None) -> None:
        """A packet at ``when``; each cycle's records are put in time order at its end."""
        record_ack = None if self.s.separate_acks else ack
        speed = Speed.S400
        record = BusRecord(
            when, RecordType.async_packet, data, self.generation, sender, speed, record_ack
        )
        self.records.append(record)
        if self.s.separate_acks and ack is not None:
            raw = bytes([ack_byte(ack)])
            self.records.append(BusRecord(when + 300, RecordType.ack, raw, self.generation, None))

    def read(
        self, board: int, offset: int, length: int | None, value: bytes, busy: bool, fate: str
    ) -> None:
        tl = self.label()
        node, host = LOCAL_BASE | board, LOCAL_BASE | self.host
        if length is None:
            request = self.packet(
                ("qr", tl, node, offset),
                QuadletReadRequest(destination_id=node, source_id=host, tlabel=tl, offset=offset),
            )
        else:
            request = self.packet(
                ("br", tl, node, offset, length),
                BlockReadRequest(
                    destination_id=node,
                    source_id=host,
                    tlabel=tl,
                    offset=offset,
                    data_length=length,
                ),
            )
        if busy:
            self.emit(request, self.host, AckCode.ack_busy_X, 3_000)
        self.emit(request, self.host, AckCode.ack_pending, 3_000 if not busy else 9_000)
        if fate == "lost":
            return
        if length is None:
            response = self.packet(
                ("qp", tl, node, value),
                QuadletReadResponse(
                    destination_id=host,
                    source_id=node,
                    tlabel=tl,
                    quadlet_data=int.from_bytes(value, "big"),
                ),
            )
        else:
            response = self.packet(
                ("bp", tl, node, value),
                BlockReadResponse(destination_id=host, source_id=node, tlabel=tl, data=value),
            )
        if fate == "corrupt":
            response = response[:-1] + bytes([response[-1] ^ 0x5A])
        # A third of the answers come right after the ack (concatenated); the rest
        # take tens of microseconds while the host goes on (split).
        if self.random.random() < 0.3:
            latency = self.random.randint(900, 2_500)
        else:
            latency = int(self.random.lognormvariate(10, 0.35))
        self.at(self.now + latency, response, board, AckCode.ack_complete)

    def write(self, board: int, data: bytes) -> None:
        tl = self.label()
        node, host = LOCAL_BASE | board, LOCAL_BASE | self.host
        request = self.packet(
            ("bw", tl, node, data),
            BlockWriteRequest(destination_id=node, source_id=host, tlabel=tl, offset=0, data=data),
        )
        self.emit(request, self.host, AckCode.ack_complete, 3_000)

    def bus_reset(self) -> None:
        self.generation = (self.generation + 1) % 256
        self.now += 200_000
        self.records.append(BusRecord(self.now, RecordType.bus_reset, b"", self.generation))
        for phy in range(self.host + 1):
            self_id = SelfIdPacket(
                phy_id=phy,
                link_active=True,
                gap_count=5,
                scode=Speed.S400,
                port0=3 if phy == self.host else 2,
            )
            self.now += 1_000
            self.records.append(
                BusRecord(
                    self.now,
                    RecordType.phy_packet,
                    encode(self_id),
                    self.generation,
                    phy,
                    Speed.S100,
                )
            )
        for board in range(self.s.boards):
            for index, quadlet in enumerate(self.roms[board]):
                offset = CSR_BASE + CONFIG_ROM + 4 * index
                self.read(board, offset, None, quadlet.to_bytes(4, "big"), False, "ok")

    def unsolicited(self) -> None:
        node, host = LOCAL_BASE, LOCAL_BASE | self.host
        stray = QuadletReadResponse(
            destination_id=host,
            source_id=node,
            tlabel=63,  # not a node ID: the highest tlabel
            quadlet_data=0xDEAD,
        )
        self.emit(encode(stray), 0, AckCode.ack_complete, 4_000)


def _due(cycle: int, every: int, board: int) -> bool:
    # Mid-period, and a different cycle for each board, so events do not pile up.
    return cycle % every == (every // 2 + board) % every


def simulate(count: int, scenario: Scenario | None = None) -> Iterator[BusRecord]:
    """At least ``count`` records of simulated traffic (whole cycles), in time order."""
    bus = _Bus(scenario or Scenario())
    s = bus.s
    bus.bus_reset()
    produced, cycle = 0, 0
    samples = [bytes(bus.random.getrandbits(8) for _ in range(RT_BLOCK_BYTES)) for _ in range(8)]
    command = bytes(range(COMMAND_BYTES))
    while produced < count:
        cycle += 1
        start = bus.now
        if cycle % s.reset_every == 0:
            bus.bus_reset()
        for board in range(s.boards):
            fate = "ok"
            if _due(cycle, s.lost_every, board):
                fate = "lost"
            elif _due(cycle, s.corrupt_every, board):
                fate = "corrupt"
            busy = _due(cycle, s.busy_every, board)
            bus.read(board, 0, RT_BLOCK_BYTES, samples[(cycle + board) % len(samples)], busy, fate)
        for board in range(s.boards):
            bus.write(board, command)
        if cycle % 50 == 0:
            bus.read(cycle % s.boards, 0, None, (0x514C4131).to_bytes(4, "big"), False, "ok")
        if cycle % s.unsolicited_every == 0:
            bus.unsolicited()
        bus.now = max(bus.now, start + s.cycle_ns)
        produced += len(bus.records)
        bus.records.sort(key=lambda record: record.timestamp_ns)
        yield from bus.records
        bus.records.clear()
