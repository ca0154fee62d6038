"""Reading a watched board: the bus traffic of one refresh.

A refresh is one real-time block read (everything the host library latches),
one quadlet read of the watchdog period and one of each channel's DAC
register, whose read-back is the only way to see the motor command another
host left there. The pot settings (wiper, speed/torque switch) need the
two-transaction pot handshake, so they are read once and on request, not
every refresh.
"""

from __future__ import annotations

from fw1394.boards.snake2010.regmap import REGISTER_MAP
from fw1394.boards.snake2010.rt_blocks import BlockSizeError
from fw1394.boards.snake2010.spec import WATCHDOG_PERIOD_MASK
from fw1394.engine.space import SpaceError
from fw1394.host import Board, BoardError, Port, UnknownNodeError
from fw1394.host.adapter_port import AdapterError
from fw1394.transport.bus_host import BusError, TransactionError
from fw1394.watch.readings import BoardReading, PotSettings, reading_of

_WATCHDOG_PERIOD = REGISTER_MAP.offset("WATCHDOG_PERIOD")

#: What a refresh can run into with a board that is gone or misbehaving; the live
#: view shows these and carries on, the snapshot reports them.
BOARD_ERRORS = (
    TransactionError,
    AdapterError,
    BusError,
    BoardError,
    BlockSizeError,
    UnknownNodeError,
    SpaceError,
)


class WatchedBoard:
    """A board on the bus, with what the view last learned about it."""

    def __init__(self, port: Port, node: int, kind: str, channels: int) -> None:
        self.port = port
        self.node = node
        self.kind = kind
        self.board = Board(port, node, channels)
        self.pot_settings: list[PotSettings | None] = [None] * channels
        self.reading: BoardReading | None = None
        self.problem: str | None = None

    @property
    def channels(self) -> int:
        return self.board.num_axes

    def read_pot_settings(self) -> None:
        """Wiper and switches of every channel, through the pot handshake."""
        self.pot_settings = [
            PotSettings(
                self.board.get_digital_pot_wiper(axis), self.board.get_analog_switches(axis)
            )
            for axis in range(self.channels)
        ]

    def sample(self) -> BoardReading:
        """Latch the inputs and read the registers the real-time block leaves out."""
        self.board.latch_all_inputs()
        period = self.port.read_quadlet(self.node, _WATCHDOG_PERIOD) & WATCHDOG_PERIOD_MASK
        dac_words = [
            self.port.read_quadlet(self.node, REGISTER_MAP.offset("DAC", axis + 1))
            for axis in range(self.channels)
        ]
        self.reading = reading_of(self.board, self.kind, dac_words, period, self.pot_settings)
        self.problem = None
        return self.reading

    def refresh(self) -> None:
        """Sample, keeping the previous reading and noting the problem if it fails."""
        try:
            self.sample()
        except BOARD_ERRORS as error:
            self.problem = f"refresh failed: {error}"
