"""The host's real-time loop: ReadAllBoards and WriteAllBoards, per protocol.

Reads: one block read of the real-time block per board (sequential), or a
broadcast query to 0x1800 followed by the hub's data (the unasked response
in Ethernet-only mode, else, or after 20 ms, a block read of hub memory).
Writes: one block write per board, or one broadcast block write carrying
every board's block in board order. Block layouts per firmware revision are
those of jhu-eth1394.md §4.5-4.6.
"""

from __future__ import annotations

import os
import select
import struct
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from fw1394.boards.qla1 import rt_blocks as rt
from fw1394.boards.qla1.regs import (
    CHANNELS,
    DAC_BOARD_ID_SHIFT,
    DAC_MIDRANGE,
    DAC_VALID,
    HUB_MEMORY_BASE,
    HUB_QUERY,
    BoardRegister,
)
from fw1394.jhu.client import HOST_SOURCE_ID, LOCAL_BUS_IDS, MAX_DATAGRAM, EthUdpClient
from fw1394.jhu.hub_parse import HubBoard, HubPlan, hub_read_quadlets
from fw1394.jhu.scan import Protocol, ScanResult
from fw1394.packets import QuadletReadRequest
from fw1394.packets.eth1394 import BROADCAST_NODE
from fw1394.packets.eth1394_fast import request_datagram
from fw1394.packets.fast import encode_packet

SEQUENCE_LIMIT = 0xFFFF


def quadlets(data: bytes) -> list[int]:
    """The whole big-endian quadlets of ``data`` (a partial last one is left out)."""
    return list(struct.unpack_from(f">{len(data) // 4}I", data))


def pack(words: Sequence[int]) -> bytes:
    return struct.pack(f">{len(words)}I", *words)


@dataclass(frozen=True)
class Command:
    """What the loop sends one board each cycle: 4 DAC words and the control quadlet."""

    dac: tuple[int, ...] = (DAC_VALID | DAC_MIDRANGE,) * CHANNELS
    control: int = 0


def write_block(board_id: int, firmware: int, command: Command) -> list[int]:
    """One board's real-time write block (Rev 1-6: the DAC words only).

    Before Rev 8 every DAC command carries the board id in bits 27..24, as the
    library's write buffer does: that is how a board finds its own commands in
    a broadcast write.
    """
    if firmware >= 8:
        return [board_id << 8 | CHANNELS + 2, *command.dac, command.control]
    tagged = [value & ~(0xF << DAC_BOARD_ID_SHIFT) | board_id << DAC_BOARD_ID_SHIFT
              for value in command.dac]  # fmt: skip
    if firmware == 7:
        return [*tagged, command.control]
    return tagged


@dataclass
class RealTimeLoop:
    """Cycles of the host's loop over the boards a scan found."""

    client: EthUdpClient
    scan: ScanResult
    protocol: Protocol | None = None
    sequence: int = 0

    def __post_init__(self) -> None:
        if self.protocol is None:
            self.protocol = self.scan.protocol
        self.boards = sorted(self.scan.boards, key=lambda board: board.board_id)
        self.mask = sum(1 << board.board_id for board in self.boards)
        # Fixed for the run: worked out once, not every cycle.
        self._read_quadlets = [rt.rt_read_quadlets(board.firmware) for board in self.boards]
        self._hub_boards = [HubBoard(board.board_id, board.firmware) for board in self.boards]
        self._hub_plan: HubPlan | None = None
        # The hub's layout follows the firmware: raises MixedFirmwareError for a broadcast
        # read over boards of different families, which the host refuses too.
        self._hub_size = 0
        if self.protocol is Protocol.BC_QRW:
            self._hub_size = 4 * hub_read_quadlets(self._hub_boards)
            self._hub_plan = HubPlan.of(self._hub_boards)
        self._idle_words = [
            write_block(board.board_id, board.firmware, Command()) for board in self.boards
        ]
        #: The broadcast write of a cycle with no commands: every board idle.
        self._idle_data = pack([word for words in self._idle_words for word in words])
        #: Hub memory's quadlets, unpacked by a format made once.
        self._hub_format = struct.Struct(f">{self._hub_size // 4}I")

    # -- reads --------------------------------------------------------------------------
    def read_all(self) -> dict[int, list[int] | None]:
        """Board ID -> real-time block (None where the read failed)."""
        if self.protocol is Protocol.BC_QRW:
            return self._read_broadcast()
        blocks: dict[int, list[int] | None] = {}
        for board, count in zip(self.boards, self._read_quadlets, strict=True):
            data = self.client.read_block_node(board.node, 0, 4 * count)
            blocks[board.board_id] = None if data is None else quadlets(data)
        return blocks

    def _read_broadcast(self) -> dict[int, list[int] | None]:
        client = self.client
        self.sequence = self.sequence % SEQUENCE_LIMIT + 1
        size = self._hub_size
        client.flush()
        query = (self.sequence << 16) | self.mask
        if not client.write_quadlet_node(BROADCAST_NODE, HUB_QUERY, query):
            return dict.fromkeys((b.board_id for b in self.boards), None)
        query_tl = client.state.tl
        data = None
        # The library sleeps a fixed few microseconds (per board) before its one
        # receive; here the receive's own wait covers it, and ends as soon as the
        # answer is in (a sleep that short lasts far longer on a busy machine).
        if not client.state.use_bridge:
            data = client.receive_broadcast_response(query_tl, size)
        if data is None:
            hub = self.scan.node_of(client.state.hub_board)
            data = client.read_block_node(hub, HUB_MEMORY_BASE, size)
        return self._split_hub(data)

    def _split_hub(self, data: bytes | None) -> dict[int, list[int] | None]:
        if data is None:
            return dict.fromkeys((board.board_id for board in self.boards), None)
        plan = self._hub_plan or HubPlan.of(self._hub_boards)
        hub_format = self._hub_format
        words = hub_format.unpack(data) if len(data) == hub_format.size else quadlets(data)
        return plan.split(words, self.sequence)

    # -- writes -------------------------------------------------------------------------
    def write_all(self, commands: dict[int, Command] | None = None) -> bool:
        commands = commands or {}
        if self.protocol in (Protocol.SEQ_R_BC_W, Protocol.BC_QRW):
            data = self._idle_data
            if commands:
                words: list[int] = []
                for board, idle in zip(self.boards, self._idle_words, strict=True):
                    command = commands.get(board.board_id)
                    if command is None:
                        words += idle
                    else:
                        words += write_block(board.board_id, board.firmware, command)
                data = pack(words)
            ok = self.client.write_block_node(BROADCAST_NODE, 0, data)
            for board in self.boards:
                if board.firmware < 7:
                    command = commands.get(board.board_id, Command())
                    ok &= self._old_control(board.node, command, after_broadcast=True)
            return ok
        ok = True
        for board in self.boards:
            ok &= self._write_one(board.node, board.board_id, board.firmware, commands)
        return ok

    def _write_one(
        self, node: int, board_id: int, firmware: int, commands: dict[int, Command]
    ) -> bool:
        command = commands.get(board_id, Command())
        words = write_block(board_id, firmware, command)
        ok = self.client.write_block_node(node, 0, pack(words))
        if firmware >= 7:
            return ok
        return ok & self._old_control(node, command, after_broadcast=False)

    def _old_control(self, node: int, command: Command, *, after_broadcast: bool) -> bool:
        """Rev 1-6: the control quadlet as its own write (if not zero), and a no-op write
        to feed the watchdog when no DAC command has its valid bit; after a broadcast
        write the library skips the no-op if it wrote the control quadlet."""
        ok = True
        if command.control:
            ok &= self.client.write_quadlet_node(node, BoardRegister.STATUS, command.control)
        if not any(value & DAC_VALID for value in command.dac) and not (
            after_broadcast and command.control
        ):
            ok &= self.client.write_quadlet_node(node, BoardRegister.STATUS, 0)
        return ok

    def cycle(self, commands: dict[int, Command] | None = None) -> dict[int, list[int] | None]:
        """One read of every board, then one write; the blocks read."""
        blocks = self.read_all()
        self.write_all(commands)
        return blocks


# -- how fast the loop runs, beside the machine's floor ---------------------------------------


@dataclass(frozen=True)
class RateReport:
    """A run of the loop, interleaved with raw UDP ping-pongs to the same boards."""

    protocol: str
    boards: int
    cycles: int
    complete: int
    loop_seconds: float
    loop_cpu_seconds: float
    pings: int
    ping_seconds: float
    load: float

    def as_dict(self) -> dict[str, float | int | str]:
        return {
            "protocol": self.protocol,
            "boards": self.boards,
            "cycles": self.cycles,
            "complete": self.complete,
            "mean_cycle_ms": 1e3 * self.loop_seconds / max(self.cycles, 1),
            "loop_hz": self.cycles / self.loop_seconds if self.loop_seconds else 0.0,
            "client_cpu_ms_per_cycle": 1e3 * self.loop_cpu_seconds / max(self.cycles, 1),
            "ping_pong_ms": 1e3 * self.ping_seconds / max(self.pings, 1),
            "ping_pong_hz": self.pings / self.ping_seconds if self.ping_seconds else 0.0,
            "load_1min": self.load,
        }


def ping_pong(client: EthUdpClient, node: int) -> Callable[[], bool]:
    """One bare round trip to ``node``: a prebuilt quadlet read out, its datagram back.

    The floor a loop cycle (at least one round trip) cannot beat on this machine
    right now: no flush, no checks, no bookkeeping.
    """
    request = QuadletReadRequest(
        destination_id=LOCAL_BUS_IDS | node,
        tlabel=0,
        source_id=HOST_SOURCE_ID,
        offset=BoardRegister.HARDWARE_VERSION,
    )
    payload = request_datagram(not client.state.use_bridge, client.state.generation,
                               encode_packet(request))  # fmt: skip
    address = (client.destination(node, False), client.port)
    sock, timeout = client.sock, client.receive_timeout

    def once() -> bool:
        sock.sendto(payload, address)
        if not select.select([sock], [], [], timeout)[0]:
            return False
        sock.recv(MAX_DATAGRAM)
        return True

    return once


def measure(loop: RealTimeLoop, cycles: int, chunk: int = 50) -> RateReport:
    """``cycles`` cycles of ``loop`` in chunks, each chunk followed by as many ping-pongs."""
    assert loop.protocol is not None
    ping = ping_pong(loop.client, loop.boards[0].node)
    complete = pings = 0
    loop_seconds = loop_cpu = ping_seconds = 0.0
    done = 0
    while done < cycles:
        count = min(chunk, cycles - done)
        started, cpu = time.perf_counter(), time.process_time()
        for _ in range(count):
            blocks = loop.cycle()
            complete += all(block is not None for block in blocks.values())
        loop_seconds += time.perf_counter() - started
        loop_cpu += time.process_time() - cpu
        loop.client.flush()
        started = time.perf_counter()
        for _ in range(count):
            pings += ping()
        ping_seconds += time.perf_counter() - started
        done += count
    return RateReport(
        loop.protocol.value,
        len(loop.boards),
        cycles,
        complete,
        loop_seconds,
        loop_cpu,
        pings,
        ping_seconds,
        os.getloadavg()[0],
    )
