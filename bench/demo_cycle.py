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
* node, real-time block write: the 7-quadlet DAC write, same baseline;
* physics: 1 ms of 7 moving motors, one exponential per motor
  (``MotorAxis.run``) against one step per 0.25 ms grid step (the reference).

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

from fw1394.boards.memory.board import MemorySpace
from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.boards.snake2010.physics import MotorAxis
from fw1394.boards.snake2010.rt_blocks import realtime_read_length
from fw1394.boards.snake2010.spec import ENCODER_MIDPOINT
from fw1394.cli.dissect import positive
from fw1394.demo.run import AXES_PER_BOARD, GAINS, trajectory
from fw1394.engine import Responder
from fw1394.engine.fast_responder import FastResponder
from fw1394.engine.policy import POLICIES
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.host import Board, MultiBoard, PositionLoop
from fw1394.host.units import count_difference, dac_code
from fw1394.packets import BlockReadRequest, BlockWriteRequest
from fw1394.packets.fast import encode_packet
from fw1394.packets.nodeid import node_id

HOST, ME = node_id(62), node_id(0)
CHANNELS = 7
MILLISECOND = TICKS_PER_SECOND // 1000
STEP_TICKS = 12_288  # the board's physics grid

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


def _commands(cycle: int) -> bytes:
    codes = [0x8000 + int(12_000 * math.sin(cycle / 50 + k)) for k in range(CHANNELS)]
    return struct.pack(f">{CHANNELS}I", *[1 << 31 | code for code in codes])


def responder_cycle(space_kind: str, which: str) -> Piece:
    """``which`` ("read" or "write") of a demo cycle on a snake2010 or memory node."""
    space = _moving_snake() if space_kind == "snake2010" else MemorySpace(4096)
    fast = FastResponder(Responder(ME, space, POLICIES["thesis"]))
    length = realtime_read_length(CHANNELS)
    read = encode_packet(
        BlockReadRequest(destination_id=ME, source_id=HOST, tlabel=1, offset=0, data_length=length)
    )
    writes = [
        encode_packet(
            BlockWriteRequest(destination_id=ME, source_id=HOST, tlabel=1, offset=0, data=data)
        )
        for data in map(_commands, range(64))
    ]
    clock = [0.0]

    def run(cycles: int) -> None:
        # Both transactions go on every cycle (the write moves the motors); only
        # ``which`` is timed, so the other one's time is taken out again.
        serve, now = fast.serve, clock[0]
        timer, spent = time.process_time, 0.0
        for cycle in range(cycles):
            now += 0.001
            if which == "read":
                started = timer()
                serve(read, 0, now)
                spent += timer() - started
                serve(writes[cycle % 64], 0, now)
            else:
                serve(read, 0, now)
                started = timer()
                serve(writes[cycle % 64], 0, now)
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
        ("physics, 7 motors, 1 ms, one span", physics(jump=True),
         "one step per 0.25 ms", physics(jump=False)),
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
