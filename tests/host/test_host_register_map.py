"""The host library's quadlet transactions land where the board's register map says."""

from __future__ import annotations

from fw1394.boards.registry import BOARDS, make_board
from fw1394.boards.regmap import FIREWIRE
from fw1394.engine.space import AddressSpace
from fw1394.host import Board, LocalPort, ManualClock


class RecordingPort(LocalPort):
    """A :class:`LocalPort` that notes each quadlet access as (operation, offset)."""

    def __init__(self, nodes: dict[int, AddressSpace], clock: ManualClock) -> None:
        super().__init__(nodes, clock)
        self.quadlets: list[tuple[str, int]] = []

    def read_quadlet(self, node: int, offset: int) -> int:
        self.quadlets.append(("read", offset))
        return super().read_quadlet(node, offset)

    def write_quadlet(self, node: int, offset: int, value: int) -> None:
        self.quadlets.append(("write", offset))
        super().write_quadlet(node, offset, value)


def exercise(board: Board) -> None:
    for axis in range(board.num_axes):
        board.set_encoder_preload(axis, 0x800000)
        board.set_motor_current(axis, 0x9000)
        board.set_digital_pot_wiper(axis, 300 + axis)
        board.get_digital_pot_wiper(axis)
        board.set_analog_switches(axis, 1)
        board.get_analog_switches(axis)
    board.set_eeprom_data_float(3, 1.5)
    board.get_eeprom_data_float(3)
    board.set_power_control(board.power_word(range(board.num_axes), on=True))
    board.apply_all_outputs()
    board.latch_all_inputs()


def test_every_quadlet_the_host_sends_hits_a_register_that_allows_it() -> None:
    for kind in ("snake2010", "snake2010-ztheta"):
        registers = BOARDS[kind].registers
        assert registers is not None
        space = make_board(kind, board_id=2)
        port = RecordingPort({0: space}, ManualClock())
        board = Board(port, 0, channels=len(registers.group("channel").copies))
        exercise(board)
        assert board.board_id == 2
        names = set()
        for operation, offset in port.quadlets:
            spot = registers.at(registers.decode(offset, FIREWIRE))
            assert spot is not None, (kind, operation, hex(offset))
            allowed = {"read": ("ro", "rw"), "write": ("rw", "wo")}[operation]
            assert spot.register.access in allowed, (kind, operation, spot.register.name)
            names.add(spot.register.name)
        assert names == {"STATUS", "DAC", "ENCODER_PRELOAD", "POT_CONTROL", "POT_DATA"}


def test_the_host_reads_back_what_it_wrote_at_the_maps_offsets() -> None:
    registers = BOARDS["snake2010"].registers
    assert registers is not None
    space = make_board("snake2010", board_id=0)
    board = Board(LocalPort({0: space}, ManualClock()), 0)
    board.set_encoder_preload(4, 0x123456)
    assert space.read_quadlet(registers.offset("ENCODER_PRELOAD", 5)) == 0x123456
    assert space.read_quadlet(registers.offset("ENCODER_DATA", 5)) & 0xFFFFFF == 0x123456
