"""The digital potentiometer of one channel, reached through two registers.

Thesis sections 5.2 and 6.2: a 10-bit wiper that sets the current-feedback
gain, 14 words of 16-bit EEPROM and two digital outputs (O1 selects speed or
torque control). The pot is not sampled continuously like the ADC: the host
writes a command to the pot control register, the FPGA runs the SPI exchange
and keeps the answer, and the host then reads the pot data register. The
command frame and the data-register layout are invented (see
:mod:`fw1394.boards.snake2010.spec`).

On the real board the exchange pauses the channel's ADC (reads) or DAC
(writes) for one SPI frame, a few microseconds; that is shorter than any bus
transaction measured in thesis section 8.2, so the emulation finishes the
exchange within the write transaction and the pause cannot be observed.
"""

from __future__ import annotations

from fw1394.boards.snake2010.spec import (
    OUTPUT_O1,
    OUTPUT_O2,
    POT_ADDRESS_SHIFT,
    POT_COMMAND_SHIFT,
    POT_DATA_MASK,
    POT_DATA_VALID,
    POT_ECHO_MASK,
    POT_EEPROM_WORDS,
    WIPER_MAX,
    PotCommand,
)

#: Power-up wiper: the thesis suggests 375 (gain about 2) for the snake
#: motors; we assume it was stored in the pot's non-volatile wiper memory.
NOMINAL_WIPER = 375
#: Invented: user EEPROM words read as erased (all ones) until written.
ERASED_WORD = 0xFFFF
FRAME_MASK = 0x00FF_FFFF


class DigitalPot:
    """Wiper, EEPROM, outputs and the FPGA-side control/data registers."""

    def __init__(self) -> None:
        self.wiper = NOMINAL_WIPER
        self.outputs = OUTPUT_O1  # invented power-up state: speed control
        self.eeprom = [ERASED_WORD] * POT_EEPROM_WORDS
        self.control = 0  # last frame written, read back as is
        self.data = 0  # answer to the last command

    @property
    def speed_mode(self) -> bool:
        """True when O1 is high, which feeds motor current back (speed control)."""
        return bool(self.outputs & OUTPUT_O1)

    def execute(self, value: int) -> None:
        """Run the command frame written to the pot control register."""
        frame = value & FRAME_MASK
        self.control = frame
        command = (frame >> POT_COMMAND_SHIFT) & 0xF
        address = (frame >> POT_ADDRESS_SHIFT) & 0xF
        answer = self._run(command, address, frame & POT_DATA_MASK)
        echo = frame & POT_ECHO_MASK  # lets the host match answer to question
        self.data = echo if answer is None else POT_DATA_VALID | echo | answer

    def _run(self, command: int, address: int, data: int) -> int | None:
        """Carry out one command; return the word read, None for writes."""
        word_ok = address < POT_EEPROM_WORDS
        if command == PotCommand.READ_WIPER:
            return self.wiper
        if command == PotCommand.WRITE_WIPER:
            self.wiper = data & WIPER_MAX  # only 10 bits reach the pot
        elif command == PotCommand.READ_EEPROM and word_ok:
            return self.eeprom[address]
        elif command == PotCommand.WRITE_EEPROM and word_ok:
            self.eeprom[address] = data
        elif command == PotCommand.READ_OUTPUTS:
            return self.outputs
        elif command == PotCommand.WRITE_OUTPUTS:
            self.outputs = data & (OUTPUT_O1 | OUTPUT_O2)
        # Unknown commands and EEPROM words 14-15 do nothing.
        return None
