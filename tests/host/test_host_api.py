"""Host library tests: the three layers of thesis section 7 over emulated boards.

Conversions are checked against section 7.2 (ADC + 8192, DAC mid-point,
equation (1), a float as two 16-bit EEPROM words, EEPROM index with the
channel in bits 7-4) and the block discipline against section 7.1 (one block
read per node to latch, one block write per node to apply, valid bits).
"""

from __future__ import annotations

import struct
import time
from collections.abc import Callable, Mapping

import pytest

from fw1394.boards.snake2010.board import Snake2010Board
from fw1394.engine.space import AddressSpace, DataError
from fw1394.host import (
    Board,
    BoardError,
    LocalPort,
    ManualClock,
    MultiBoard,
    PdGains,
    PositionLoop,
    RobotIO,
    Trajectory,
    UnknownNodeError,
)
from fw1394.host.units import (
    adc_to_unsigned,
    count_difference,
    dac_code,
    eeprom_index,
    float_to_words,
    words_to_float,
)

MS = 49_152
MIDPOINT = 0x80_0000
VALID = 1 << 31


class RecordingPort(LocalPort):
    """LocalPort that remembers every transaction, to count bus traffic."""

    def __init__(self, nodes: Mapping[int, AddressSpace], clock: Callable[[], int]) -> None:
        super().__init__(nodes, clock)
        self.log: list[tuple[str, int, int, object]] = []

    def read_quadlet(self, node: int, offset: int) -> int:
        self.log.append(("qread", node, offset, None))
        return super().read_quadlet(node, offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self.log.append(("qwrite", node, offset, value))
        super().write_quadlet(node, offset, value)

    def read_block(self, node: int, offset: int, length: int) -> bytes:
        self.log.append(("bread", node, offset, length))
        return super().read_block(node, offset, length)

    def write_block(self, node: int, offset: int, data: bytes) -> None:
        self.log.append(("bwrite", node, offset, data))
        super().write_block(node, offset, data)


@pytest.fixture
def clock() -> ManualClock:
    return ManualClock()


@pytest.fixture
def emulator() -> Snake2010Board:
    return Snake2010Board(board_id=6)


@pytest.fixture
def port(emulator: Snake2010Board, clock: ManualClock) -> RecordingPort:
    return RecordingPort({3: emulator}, clock)


@pytest.fixture
def board(port: RecordingPort) -> Board:
    return Board(port, node=3)


def loopback_board(clock: ManualClock) -> tuple[Board, Snake2010Board]:
    bench = Snake2010Board(board_id=0, wiring="loopback")
    return Board(LocalPort({0: bench}, clock), node=0), bench


# --- units (section 7.2) -----------------------------------------------------


def test_adc_conversion_adds_the_14_bit_midpoint() -> None:
    assert adc_to_unsigned(0x2000) == 0  # -8192 (0 V)
    assert adc_to_unsigned(0xE000) == 0  # the same, sign-extended to 16 bits
    assert adc_to_unsigned(0x0000) == 8192  # 1.25 V
    assert adc_to_unsigned(0x1FFF) == 16383  # +8191


def test_dac_commands_are_centred_on_0x8000() -> None:
    assert dac_code(0) == 0x8000
    assert dac_code(-0x8000) == 0 and dac_code(0x7FFF) == 0xFFFF
    assert dac_code(10**6) == 0xFFFF and dac_code(-(10**6)) == 0


def test_float_split_into_two_16_bit_words() -> None:
    assert float_to_words(1.0) == (0x3F80, 0x0000)  # IEEE single 0x3F800000
    assert float_to_words(-2.5) == (0xC020, 0x0000)
    assert words_to_float(0x4049, 0x0FDB) == pytest.approx(3.14159265, rel=1e-7)


def test_eeprom_index_puts_the_channel_in_bits_7_to_4() -> None:
    assert eeprom_index(2, 5) == 0x25
    with pytest.raises(ValueError):
        eeprom_index(0, 14)  # only 14 words


def test_counter_difference_survives_24_bit_wrap() -> None:
    assert count_difference(0x00_0002, 0xFF_FFFE) == 4
    assert count_difference(0xFF_FFFE, 0x00_0002) == -4


# --- LocalPort ----------------------------------------------------------------


def test_local_port_brings_the_node_clock_up_before_each_transaction(
    port: RecordingPort, emulator: Snake2010Board, clock: ManualClock
) -> None:
    clock.advance(1234)
    port.read_quadlet(3, 0)
    assert emulator.now == 1234
    clock.advance_seconds(0.001)
    port.sync()
    assert emulator.now == 1234 + MS


def test_local_port_reports_missing_nodes_and_board_errors(port: RecordingPort) -> None:
    with pytest.raises(UnknownNodeError):
        port.read_quadlet(9, 0)
    with pytest.raises(DataError):
        port.read_block(3, 0, 4096)


# --- Board: block discipline (section 7.1) -----------------------------------


def test_latch_is_one_block_read_and_apply_one_block_write(
    board: Board, port: RecordingPort
) -> None:
    board.latch_all_inputs()
    board.set_motor_voltage(0, 0x9000)
    board.set_motor_voltage(4, 0x7000)
    board.apply_all_outputs()
    assert [entry[0] for entry in port.log] == ["bread", "bwrite"]
    _, node, offset, length = port.log[0]
    assert (node, offset, length) == (3, 0, 128)  # 32 quadlets for 7 axes
    data = port.log[1][3]
    assert isinstance(data, bytes)
    words = struct.unpack(">7I", data)
    assert words == (VALID | 0x9000, 0, 0, 0, VALID | 0x7000, 0, 0)
    board.apply_all_outputs()  # nothing set: the block goes out all invalid
    assert port.log[-1][3] == bytes(28)


def test_power_control_is_buffered_until_apply(
    board: Board, port: RecordingPort, emulator: Snake2010Board
) -> None:
    board.set_power_control(board.power_word([0, 2], on=True))
    assert emulator.status & 0xFF == 0
    board.apply_all_outputs()
    assert emulator.status & 0xFF == 0b101
    assert port.log[-1] == ("qwrite", 3, 0, 0x0505)
    board.set_power_control(board.power_word([2], on=False))
    board.apply_all_outputs()
    assert emulator.status & 0xFF == 0b001


def test_status_and_timestamp_come_from_the_latched_block(board: Board, clock: ManualClock) -> None:
    board.latch_all_inputs()
    assert board.get_status() >> 24 & 0xF == 6 == board.board_id
    clock.advance(MS)
    board.latch_all_inputs()
    assert board.get_timestamp() == MS


def test_analog_position_and_current_read_back_the_dacs(clock: ManualClock) -> None:
    # Section 8.1 loopback: DAC A into the pot input, DAC B into the current input.
    board, _ = loopback_board(clock)
    board.set_motor_current(1, 0xFFFF)
    for code, expected in ((0x0000, 0), (0x8000, 8192), (0xFFFF, 16383), (0x4000, 4096)):
        board.set_motor_voltage(1, code)
        board.apply_all_outputs()
        board.latch_all_inputs()
        assert board.get_analog_position(1) == expected
        assert board.get_motor_current(1) == 16383


def test_motor_current_limit_is_its_own_transaction(
    board: Board, port: RecordingPort, emulator: Snake2010Board
) -> None:
    board.set_motor_current(2, 0x1234)
    assert len(port.log) == 1 and port.log[0][0] == "qwrite"
    assert emulator.read_quadlet(0x31) == 0x1234_8000  # limit set, command untouched


def test_encoder_preload_overflow_and_velocity(board: Board, clock: ManualClock) -> None:
    board.set_encoder_preload(0, MIDPOINT)
    board.set_encoder_preload(1, MIDPOINT)
    board.set_motor_voltage(0, 0x8800)
    board.set_motor_voltage(1, 0x7800)
    board.set_power_control(board.power_word([0, 1, 2], on=True))
    board.apply_all_outputs()
    clock.advance(100 * MS)
    board.latch_all_inputs()
    assert board.get_encoder_position(0) > MIDPOINT
    assert board.get_encoder_position(1) < MIDPOINT
    assert board.get_encoder_velocity(0) > 0 > board.get_encoder_velocity(1)
    assert not board.get_encoder_overflow(0)
    # Axis 2 was never preloaded; run it backwards below zero.
    board.set_motor_voltage(2, 0x7000)
    board.apply_all_outputs()
    clock.advance(50 * MS)
    board.latch_all_inputs()
    assert board.get_encoder_overflow(2)


def test_digital_pot_wiper_and_feedback_gain(board: Board, port: RecordingPort) -> None:
    board.set_digital_pot_wiper(5, 375)
    port.log.clear()
    assert board.get_digital_pot_wiper(5) == 375
    # Section 6.2 handshake: a write to the control register, then a read.
    assert [(kind, offset) for kind, _, offset, _ in port.log] == [
        ("qwrite", 0x62),
        ("qread", 0x63),
    ]
    assert board.get_feedback_gain(5) == pytest.approx(2.0, abs=0.02)  # "nominally 2"
    board.set_digital_pot_wiper(5, 1023)
    assert board.get_feedback_gain(5) == pytest.approx(22.1 / 1.5)
    with pytest.raises(ValueError):
        board.set_digital_pot_wiper(5, 1024)


def test_analog_switches_select_speed_or_torque(board: Board) -> None:
    board.set_analog_switches(0, 0b00)
    assert board.get_analog_switches(0) == 0
    board.set_analog_switches(0, 0b11)
    assert board.get_analog_switches(0) == 0b11


def test_eeprom_raw_and_float_round_trip(board: Board, emulator: Snake2010Board) -> None:
    board.set_eeprom_data_raw(0x25, 0xCAFE)
    assert emulator.channels[2].pot.eeprom[5] == 0xCAFE  # axis 2, word 5
    assert board.get_eeprom_data_raw(0x25) == 0xCAFE
    board.set_eeprom_data_float(0x40, -2.5)
    assert emulator.channels[4].pot.eeprom[:2] == [0xC020, 0x0000]
    assert board.get_eeprom_data_float(0x40) == -2.5
    board.set_eeprom_data_float(0x6B, 1.0e-3)
    assert board.get_eeprom_data_float(0x6B) == pytest.approx(1.0e-3, rel=1e-7)
    with pytest.raises(ValueError):
        board.set_eeprom_data_float(0x0D, 1.0)  # would need a 15th word


def test_pot_handshake_without_answer_raises(clock: ManualClock) -> None:
    class SilentPot(Snake2010Board):
        def read_quadlet(self, offset: int) -> int:
            return 0 if offset & 0xF == 3 else super().read_quadlet(offset)

    board = Board(LocalPort({0: SilentPot(board_id=0)}, clock), node=0)
    with pytest.raises(BoardError):
        board.get_digital_pot_wiper(0)


def test_apply_all_outputs_feeds_the_watchdog(
    board: Board, emulator: Snake2010Board, port: RecordingPort, clock: ManualClock
) -> None:
    port.write_quadlet(3, 3, 400)  # about 2 ms
    board.set_power_control(board.power_word(range(7), on=True))
    board.apply_all_outputs()
    for _ in range(20):
        clock.advance(MS)
        board.latch_all_inputs()
        board.apply_all_outputs()
    assert emulator.status & 0xFF == 0x7F
    clock.advance(3 * MS)
    board.latch_all_inputs()
    assert board.get_status() & 0xFF == 0
    assert board.get_status() & 1 << 23


def test_axis_numbers_are_checked(board: Board) -> None:
    with pytest.raises(IndexError):
        board.set_motor_voltage(7, 0x8000)
    with pytest.raises(ValueError):
        board.set_motor_voltage(0, 0x10000)


# --- MultiBoard and the position loop -----------------------------------------


def snake_robot(clock: ManualClock) -> tuple[MultiBoard, RecordingPort]:
    """Actuation unit (7 axes) plus Z-Theta/five-bar node (4 axes)."""
    nodes = {0: Snake2010Board(board_id=0), 1: Snake2010Board(board_id=1, channels=4)}
    port = RecordingPort(nodes, clock)
    return MultiBoard([Board(port, 0, 7), Board(port, 1, 4)]), port


def test_multiboard_maps_axes_and_combines_status(clock: ManualClock) -> None:
    robot, _ = snake_robot(clock)
    assert isinstance(robot, RobotIO) and robot.num_axes == 11
    robot.set_power_control(robot.power_word([1, 8], on=True))
    robot.apply_all_outputs()
    robot.latch_all_inputs()
    status = robot.get_status()
    assert status & 0xFF == 0b10  # board 0, axis 1
    assert status >> 32 & 0xFF == 0b10  # board 1, its axis 1 = robot axis 8
    assert status >> 32 >> 24 & 0xF == 1  # second board's rotary switch
    robot.set_eeprom_data_raw(0x93, 0x1234)  # robot axis 9 = board 1 axis 2
    assert robot.boards[1].get_eeprom_data_raw(0x23) == 0x1234


def test_position_loop_on_eleven_axes_converges(clock: ManualClock) -> None:
    robot, port = snake_robot(clock)
    for axis in range(robot.num_axes):
        robot.set_encoder_preload(axis, MIDPOINT)
    robot.set_power_control(robot.power_word(range(robot.num_axes), on=True))
    robot.apply_all_outputs()
    offsets = [(-1) ** axis * 3000 * (axis + 1) for axis in range(robot.num_axes)]

    def ramp(offset: int) -> Trajectory:
        return lambda t: MIDPOINT + offset * min(t / 0.3, 1.0)

    loop = PositionLoop(robot, [ramp(o) for o in offsets], PdGains(kp=8.0, kd=0.01))
    port.log.clear()
    cycles = 800
    started = time.perf_counter()
    for _ in range(cycles):
        clock.advance(MS)  # 1 kHz
        errors = loop.step()
    wall = time.perf_counter() - started
    assert max(abs(e) for e in errors) <= 16  # stiction leaves a few counts
    for axis, offset in enumerate(offsets):
        assert robot.get_encoder_position(axis) - MIDPOINT == pytest.approx(offset, abs=16)
        pot_moved = robot.get_analog_position(axis) - 8192
        assert pot_moved * offset > 0  # the pot agrees with the encoder
    # One block read and one block write per node per cycle, nothing else.
    kinds = [entry[0] for entry in port.log]
    assert kinds.count("bread") == kinds.count("bwrite") == 2 * cycles
    assert len(kinds) == 4 * cycles
    # Far faster than real time: 0.8 s of robot time in well under that.
    print(f"\n11-axis 1 kHz loop: {cycles / 1000 / wall:.1f}x real time")
    assert wall < cycles / 1000


def test_position_loop_rejects_mismatched_trajectories(clock: ManualClock) -> None:
    robot, _ = snake_robot(clock)
    with pytest.raises(ValueError):
        PositionLoop(robot, [lambda t: 0.0], PdGains(kp=1.0))
