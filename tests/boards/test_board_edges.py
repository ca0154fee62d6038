"""Board details pinned to documented numbers and physical laws, written out here.

* JHU spec §2.10 (Rev 8 real-time block): timestamp, STATUS, DIGIN, TEMP, M ADC
  quadlets, then E each of position, period, QTR1, QTR5, running counter, then M
  motor status quadlets; §4.4: DAC write bit 24 selects voltage mode.
* The Dallas DS2505 holds 16 kbit (2048 bytes); the host reads it in 256-byte blocks
  from any start address and the address wraps at the end of the memory.
* IEEE 1212: SPLIT_TIMEOUT_LO powers up at 800 eighths of a millisecond (bits 31:19).
* IEEE 1212: STATE_SET at 0x004 and NODE_IDS at 0x008 take one block write.
* JHU spec: channel ADC is pot << 16 | current; hub register 0x1803 is {board id,
  mask of the lower boards}.
* The boards snoop a hub query (quadlet write to 0x1800) sent to node 0 or broadcast.
* Dry friction: a motor at rest starts only when its torque exceeds the Coulomb friction.
"""

from __future__ import annotations

import struct

from fw1394.boards import make_board
from fw1394.boards.qla1 import rt_blocks
from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.eth_server import reply_address
from fw1394.boards.qla1.ethernet import Reply, datagram
from fw1394.boards.qla1.firewire import reaches_every_node
from fw1394.boards.snake2010.physics import Drive, MotorAxis, MotorConstants
from fw1394.engine.space import TICKS_PER_SECOND
from fw1394.packets import QuadletReadRequest, QuadletWriteRequest
from fw1394.packets.eth1394 import ExtraBytes

CHANNELS = 4
DALLAS, BUFFER = 13, 0x6000
CSR = 0xFFFF_F000_0000


def test_the_rev8_real_time_block_has_the_documented_quadlets() -> None:
    m = e = CHANNELS
    places = [
        rt_blocks.TIMESTAMP, rt_blocks.STATUS, rt_blocks.DIGITAL_INPUT, rt_blocks.TEMPERATURE,
        rt_blocks.ADC, rt_blocks.ENCODER_POSITION, rt_blocks.ENCODER_PERIOD,
        rt_blocks.ENCODER_QTR1, rt_blocks.ENCODER_QTR5, rt_blocks.ENCODER_RUNNING,
        rt_blocks.MOTOR_STATUS,
    ]  # fmt: skip
    assert places == [0, 1, 2, 3, 4, 4 + m, 4 + m + e, 4 + m + 2 * e, 4 + m + 3 * e,
                      4 + m + 4 * e, 4 + m + 5 * e]  # fmt: skip
    assert rt_blocks.rt_read_quadlets(8) == 4 + 2 * m + 5 * e


def test_a_dac_write_selects_voltage_mode_with_bit_24_only() -> None:
    board = Qla1Board(board_id=0, firmware=8)
    channel = board.channels[0]
    board.write_quadlet(1 << 4 | 1, 1 << 31 | 1 << 24 | 0x9000)  # valid, voltage mode
    assert channel.voltage_mode and channel.dac_command == 0x9000
    board.write_quadlet(1 << 4 | 1, 1 << 31 | 1 << 23 | 0x9000)  # valid, bit 23 only
    assert not channel.voltage_mode


def _read_dallas(board: Qla1Board, address: int, count: int) -> bytes:
    board.write_quadlet(DALLAS, address << 16 | 2)  # read at address
    data = board.read_block(BUFFER, 256)
    while len(data) < count:
        board.write_quadlet(DALLAS, 3)  # read the next block
        data += board.read_block(BUFFER, 256)
    return data[:count]


def test_a_dallas_read_from_an_unaligned_address_wraps_at_2048_bytes() -> None:
    board = Qla1Board(board_id=0, firmware=8)
    memory = bytes(n % 251 for n in range(2048))
    board.dallas.memory = memory
    for _ in range(2000):  # the 1-wire interface answers its reset first
        if board.read_quadlet(DALLAS) & 0x20F0 == 0:
            break
    assert _read_dallas(board, 0x7F0, 512) == (memory + memory)[0x7F0 : 0x7F0 + 512]


def test_split_timeout_lo_powers_up_at_800_eighths_of_a_millisecond() -> None:
    board = make_board("qla1", board_id=1)
    assert board.read_quadlet(CSR + 0x01C) == 800 << 19
    assert board.read_quadlet(CSR + 0x018) == 0


def test_only_node_0_and_broadcast_hub_queries_reach_every_board() -> None:
    def query(destination: int) -> QuadletWriteRequest:
        return QuadletWriteRequest(destination_id=destination, offset=0x1800, quadlet_data=0)

    assert reaches_every_node(query(0xFFFF))  # broadcast
    assert reaches_every_node(query(0xFFC0))  # node 0
    assert not reaches_every_node(query(0xFFC2))
    assert not reaches_every_node(QuadletReadRequest(destination_id=0xFFC0, offset=0x1800))


def test_a_motor_at_rest_starts_only_when_its_torque_beats_coulomb_friction() -> None:
    constants = MotorConstants()
    ke, ohms = constants.motor_constant, constants.circuit_ohms
    # At rest there is no back EMF: I = V / R, torque Ke I.
    volts_for = {share: share * constants.coulomb_friction / ke * ohms for share in (0.9, 1.5)}
    for share, volts in volts_for.items():
        drive = Drive(True, volts, 1.0)
        stepped, spanned = MotorAxis(constants), MotorAxis(constants)
        stepped.advance(0.01, drive)  # one step
        spanned.run(0, TICKS_PER_SECOND // 100, 12_288, TICKS_PER_SECOND, drive)  # a span
        for motor in (stepped, spanned):
            moved = motor.velocity_rad_s != 0.0 or motor.angle_rad != 0.0
            assert moved == (share > 1.0), share


def test_reply_timers_count_49_152_mhz_ticks_from_reception_and_saturate() -> None:
    # Spec §2.5: extra bytes 4-5 (receive processing) and 6-7 (until sent), big-endian
    # 49.152 MHz ticks since the start of reception, saturating at 0xFFFF.
    reply = Reply(("127.0.0.1", 1394), b"", ExtraBytes(), received_at=8.0)
    # 2**-10 s is exactly 48,000 ticks; processing "before" reception (clock steps) is 0.
    assert datagram(reply, 8.0, 8.0 + 2**-10)[4:8] == struct.pack(">HH", 0, 48_000)
    assert datagram(reply, 7.5, 9.0)[4:8] == struct.pack(">HH", 0, 0xFFFF)


def test_a_reply_to_the_unspecified_address_goes_to_the_servers_own_address() -> None:
    # A host's multicast sent from 0.0.0.0 is answered on the server's own address.
    assert reply_address(("0.0.0.0", 5000), "127.0.0.5") == ("127.0.0.5", 5000)
    assert reply_address(("127.0.0.9", 5000), "127.0.0.5") == ("127.0.0.9", 5000)


def test_an_adc_quadlet_is_the_pot_reading_above_the_current_reading() -> None:
    # Spec §2.10: channel ADC is (pot << 16) | current; with the amplifier off the current
    # reads the DAC's midrange.
    board = Qla1Board(board_id=0, firmware=8)
    for number in range(1, CHANNELS + 1):
        adc = board.read_quadlet(number << 4 | 0)
        assert adc >> 16 == board.channels[number - 1].pot_reading
        assert adc & 0xFFFF == 0x8000


def test_hub_register_0x1803_is_the_board_id_and_the_lower_boards() -> None:
    # Spec: a 0x1800 write is {sequence 31:16, board mask 15:0}; 0x1803 reads
    # {board id, mask of the boards below this one}.
    board = Qla1Board(board_id=2, firmware=8)
    board.write_quadlet(0x1800, 7 << 16 | 0b10111)
    assert board.read_quadlet(0x1803) == 2 << 16 | 0b00011


def test_a_csr_block_write_lands_on_consecutive_registers() -> None:
    # IEEE 1212: STATE_SET at 0x004, NODE_IDS at 0x008 (a write sets the bus ID, 31:22).
    board = make_board("qla1", board_id=1)
    board.write_block(CSR + 0x004, struct.pack(">II", 1 << 8, 0x2AB << 22))
    assert board.read_quadlet(CSR + 0x000) & 1 << 8  # STATE_CLEAR reads the state
    assert board.read_quadlet(CSR + 0x008) >> 22 == 0x2AB
