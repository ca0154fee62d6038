"""Where one ``fw1394 demo`` cycle's CPU goes, piece by piece, each against a baseline.

Each piece runs in this process, without sockets, interleaved with its baseline
(A B A B ...), so both halves of a ratio come from the same machine regime:

* host servo law: ``PositionLoop.step`` for the demo's 11 axes on a port that
  answers at once (its law inline) against the
  plain cycle with the law through the unit helpers, one call per axis
  (``count_difference``, ``dac_code``), as the loop was written before;
* node, real-time block read: a snake2010 responder answering the 32-quadlet
  read with its 7 motors moving (1 ms since the previous cycle), against a
  memory node answering a read of the same length;
* node, real-time block write: the 7-quadlet DAC write, 0.33 ms after the read
  as in the demo (so the board first moves its motors that far), same baseline;
* the same read with every motor held at rest by stiction (amplifiers on, the
  writes command mid-scale), same baseline;
* physics: 1 ms of 7 moving motors, one exponential per motor
  (``MotorAxis.run``) against one step per 0.25 ms grid step (the reference);
* the demo's loop in one process: ``PositionLoop.step`` with both snake2010
  boards (7 and 4 axes) on a ``LocalPort``, each of the cycle's four
  transactions at its time in the demo's cycle, against the host law alone.

What the bus adds (system calls, wake-ups, the capture) is measured live by
``fw1394 demo`` itself (per-process CPU and wake-ups per cycle).

    python bench/demo_cycle.py [--rounds 4] [--cycles 2000]
"""

from __future__ import annotations

import argparse
import math
import statistics
import struct
import time
from collections.abc import Callable

from fw1394.boards import make_board
from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.physics import MotorAxis
from fw1394.boards.snake2010.rt_blocks import realtime_read_length
from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.cli.dissect import positive
from fw1394.demo.run import AXES_PER_BOARD, BOARDS, GAINS, trajectory
from fw1394.engine import Responder
from fw1394.engine.policy import POLICIES
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host import Board, MultiBoard, PositionLoop
from fw1394.host.port import LocalPort
from fw1394.host.units import count_difference, dac_code
from fw1394.packets import BlockReadRequest, BlockWriteRequest
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import node_id

HOST, ME = node_id(62), node_id(0)
CHANNELS = 7
MILLISECOND = TICKS_PER_SECOND // 1000
STEP_TICKS = 12_288  # the board's physics grid
#: When the demo's four transactions come in its cycle (s): read of the 7-axis
#: board, read of the 4-axis board, write of each ("Where a cycle goes" in
#: docs/performance/history.md).
TRANSACTION_TIMES = (0.0, 0.00016, 0.00033, 0.00039)
WRITE_AFTER_READ = TRANSACTION_TIMES[2] - TRANSACTION_TIMES[0]

Piece = Callable[[int], None]


class InstantPort:
    """A port whose real-time blocks come from two resting boards, answered at once."""

    def __init__(self) -> None:
        self.blocks = {
            node: Snake2010Board(board_id=node, channels=axes).read_block(
                0, realtime_read_length(axes)
            )
            for node, axes in enumerate(AXES_PER_BOARD)
        }

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        return self.blocks[node]

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        pass

    def read_quadlet(self, node: int, offset: int) -> int:
        return 0

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        pass


def servo_law() -> Piece:
    port = InstantPort()
    robot = MultiBoard([Board(port, n, a) for n, a in enumerate(AXES_PER_BOARD)])
    loop = PositionLoop(robot, [trajectory(a) for a in range(robot.num_axes)], GAINS)

    def run(cycles: int) -> None:
        for cycle in range(cycles):
            loop.cycle = cycle
            loop.step()

    return run


class DemoClock:
    """Board time of each transaction: 0 while setting up, then the demo's cycle times."""

    def __init__(self) -> None:
        self.cycle = -1  # setting up
        self.transaction = 0

    def next_cycle(self) -> None:
        self.cycle += 1
        self.transaction = 0

    def __call__(self) -> int:
        if self.cycle < 0:
            return 0
        offset = TRANSACTION_TIMES[self.transaction % len(TRANSACTION_TIMES)]
        self.transaction += 1
        return round((0.001 * (self.cycle + 1) + offset) * TICKS_PER_SECOND)


def demo_loop() -> Piece:
    clock = DemoClock()
    port = LocalPort(
        {node: make_board(kind, board_id=node) for node, kind in enumerate(BOARDS)}, clock
    )
    robot = MultiBoard([Board(port, n, a) for n, a in enumerate(AXES_PER_BOARD)])
    for axis in range(robot.num_axes):
        robot.set_encoder_preload(axis, ENCODER_MIDPOINT)
    robot.set_power_control(robot.power_word(range(robot.num_axes), on=True))
    robot.apply_all_outputs()
    loop = PositionLoop(robot, [trajectory(a) for a in range(robot.num_axes)], GAINS)

    def run(cycles: int) -> None:
        for _ in range(cycles):
            clock.next_cycle()
            loop.step()

    return run


def helper_law() -> Piece:
    """The same cycle, plain, with the law through the unit helpers axis by axis."""
    port = InstantPort()
    robot = MultiBoard([Board(port, n, a) for n, a in enumerate(AXES_PER_BOARD)])
    targets = [trajectory(a) for a in range(robot.num_axes)]
    previous: list[list[int]] = []

    def run(cycles: int) -> None:
        for cycle in range(cycles):
            t = cycle / 1000
            robot.latch_all_inputs()
            positions = robot.get_encoder_positions()
            before = previous[0] if previous else positions
            commands = []
            for axis, position in enumerate(positions):
                error = count_difference(round(targets[axis](t)), position)
                velocity = count_difference(position, before[axis]) * 1000.0
                command = GAINS.kp * error - GAINS.kd * velocity
                limit = GAINS.max_command
                commands.append(dac_code(round(min(max(command, -limit), limit))))
            robot.set_motor_voltages(commands)
            robot.apply_all_outputs()
            previous[:] = [positions]

    return run


def _moving_snake() -> Snake2010Board:
    board = Snake2010Board(board_id=0)
    for channel in range(1, CHANNELS + 1):
        board.write_quadlet(channel << 4 | 4, ENCODER_MIDPOINT)
    board.write_quadlet(0, 0x7F7F)  # every amplifier on
    return board


def _commands(cycle: int, amplitude: int = 12_000) -> bytes:
    codes = [0x8000 + int(amplitude * math.sin(cycle / 50 + k)) for k in range(CHANNELS)]
    return struct.pack(f">{CHANNELS}I", *[1 << 31 | code for code in codes])


def responder_cycle(space_kind: str, which: str) -> Piece:
    """``which`` ("read" or "write") of a demo cycle on a node: snake2010, held or memory."""
    space = MemorySpace(4096) if space_kind == "memory" else _moving_snake()
    amplitude = 0 if space_kind == "held" else 12_000
    responder = Responder(ME, space, POLICIES["thesis"])
    length = realtime_read_length(CHANNELS)
    read = encode_packet(
        BlockReadRequest(destination_id=ME, source_id=HOST, tlabel=1, offset=0, data_length=length)
    )
    writes = [
        encode_packet(
            BlockWriteRequest(destination_id=ME, source_id=HOST, tlabel=1, offset=0, data=data)
        )
        for data in (_commands(cycle, amplitude) for cycle in range(64))
    ]
    clock = [0.0]

    def run(cycles: int) -> None:
        # Both transactions go on every cycle (the write changes the drives); only
        # ``which`` is timed, so the other one's time is taken out again.
        serve, now = responder.serve, clock[0]
        timer, spent = time.process_time, 0.0
        for cycle in range(cycles):
            now += 0.001
            if which == "read":
                started = timer()
                serve(read, 0, now)
                spent += timer() - started
                serve(writes[cycle % 64], 0, now + WRITE_AFTER_READ)
            else:
                serve(read, 0, now)
                started = timer()
                serve(writes[cycle % 64], 0, now + WRITE_AFTER_READ)
                spent += timer() - started
        clock[0] = now
        run.spent = spent  # type: ignore[attr-defined]

    return run


def physics(jump: bool) -> Piece:
    motors = [MotorAxis(_moving_snake().channels[0].constants) for _ in range(CHANNELS)]
    board = _moving_snake()
    commands = [_commands(cycle) for cycle in range(64)]
    now = [0]

    def run(cycles: int) -> None:
        start = now[0]
        for cycle in range(cycles):
            end = start + MILLISECOND
            board.write_block(0, commands[cycle % 64])  # the drives the servo asks for
            for channel, motor in zip(board.channels, motors, strict=True):
                drive = channel.drive
                if jump:
                    motor.run(start, end, STEP_TICKS, TICKS_PER_SECOND, drive)
                else:
                    t = start
                    while t < end:
                        nxt = min((t // STEP_TICKS + 1) * STEP_TICKS, end)
                        motor.advance((nxt - t) / TICKS_PER_SECOND, drive)
                        t = nxt
            start = end
        now[0] = start

    return run


def timed(piece: Piece, cycles: int) -> float:
    """CPU µs per cycle of ``piece`` (its own account when it keeps one)."""
    started = time.process_time()
    piece(cycles)
    spent = getattr(piece, "spent", time.process_time() - started)
    return float(spent) / cycles * 1e6


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=positive, default=4, help="A/B pairs per piece")
    parser.add_argument("--cycles", type=positive, default=2000, help="cycles per round")
    args = parser.parse_args()
    pairs: list[tuple[str, Piece, str, Piece]] = [
        ("host servo law, inline", servo_law(),
         "plain, unit helpers", helper_law()),
        ("snake2010 real-time block read", responder_cycle("snake2010", "read"),
         "memory node, same length", responder_cycle("memory", "read")),
        ("snake2010 real-time block write", responder_cycle("snake2010", "write"),
         "memory node, same length", responder_cycle("memory", "write")),
        ("same read, motors held by stiction", responder_cycle("held", "read"),
         "memory node, same length", responder_cycle("memory", "read")),
        ("physics, 7 motors, 1 ms, one span", physics(jump=True),
         "one step per 0.25 ms", physics(jump=False)),
        ("demo loop, both boards in-process", demo_loop(),
         "host servo law alone", servo_law()),
    ]  # fmt: skip
    print(f"CPU µs per demo cycle, {args.rounds} interleaved A/B rounds of {args.cycles} cycles")
    for name, piece, base_name, base in pairs:
        mine: list[float] = []
        theirs: list[float] = []
        for _ in range(args.rounds):
            mine.append(timed(piece, args.cycles))
            theirs.append(timed(base, args.cycles))
        ratios = [a / b for a, b in zip(mine, theirs, strict=True)]
        print(
            f"{name:36} {min(mine):6.1f}-{max(mine):6.1f}   {base_name:26} "
            f"{min(theirs):6.1f}-{max(theirs):6.1f}   ratio {min(ratios):.2f}-{max(ratios):.2f} "
            f"(median {statistics.median(ratios):.2f})"
        )


if __name__ == "__main__":
    main()
