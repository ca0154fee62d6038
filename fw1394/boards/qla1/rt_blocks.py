"""Real-time block layouts of the QLA, per firmware revision.

A block read in the MAIN space returns the real-time block (timestamp,
status, digital I/O, temperature, then per-channel groups); a block write at
offset 0 carries the DAC commands and a power-control quadlet. The write
decoders here only say which registers to write; the board applies them.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from typing import NamedTuple

from fw1394.boards.qla1.regs import CHANNELS, DAC_BOARD_ID_SHIFT, DAC_VALID

#: Index of each field in the Rev 8+ block; Rev 7 and Rev < 7 are prefixes of it
#: (Rev < 7 has 4 groups, Rev 7 adds QTR5 and the running counter, Rev 8 motor status).
TIMESTAMP = 0
STATUS = 1
DIGITAL_INPUT = 2
TEMPERATURE = 3
ADC = 4
ENCODER_POSITION = ADC + CHANNELS
ENCODER_PERIOD = ENCODER_POSITION + CHANNELS
ENCODER_QTR1 = ENCODER_PERIOD + CHANNELS
ENCODER_QTR5 = ENCODER_QTR1 + CHANNELS
ENCODER_RUNNING = ENCODER_QTR5 + CHANNELS
MOTOR_STATUS = ENCODER_RUNNING + CHANNELS
#: Block reads index the block with offset bits 5..0.
RT_INDEX_MASK = 0x3F


def rt_read_quadlets(firmware: int) -> int:
    """Size of the real-time read block: 4 + 4E, 4 + 6E, 4 + 2M + 5E quadlets."""
    if firmware < 7:
        return 4 + 4 * CHANNELS
    if firmware == 7:
        return 4 + 6 * CHANNELS
    return 4 + 2 * CHANNELS + 5 * CHANNELS


def rt_write_quadlets(firmware: int) -> int:
    """Size of one board's real-time write block (header and control included)."""
    if firmware < 7:
        return CHANNELS
    if firmware == 7:
        return CHANNELS + 1
    return CHANNELS + 2


class RtSample(NamedTuple):
    """Everything a real-time read reports, in register form (a tuple: a board samples
    one every cycle)."""

    timestamp: int
    status: int
    digital_input: int
    temperature: int
    adc: Sequence[int]
    encoder_position: Sequence[int]
    encoder_period: Sequence[int]
    encoder_qtr1: Sequence[int]
    encoder_qtr5: Sequence[int]
    encoder_running: Sequence[int]
    motor_status: Sequence[int]


def rt_read_block(sample: RtSample, firmware: int) -> list[int]:
    """The real-time read block of ``firmware`` as a list of quadlets."""
    block = [sample.timestamp, sample.status, sample.digital_input, sample.temperature]
    block += sample.adc
    block += sample.encoder_position
    block += sample.encoder_period
    block += sample.encoder_qtr1
    if firmware >= 7:
        block += sample.encoder_qtr5
        block += sample.encoder_running
    if firmware >= 8:
        block += sample.motor_status
    return block


# -- block writes ---------------------------------------------------------------------


class RtWrite(NamedTuple):
    """Register writes a real-time block write asks of this board (a tuple: a broadcast
    write makes one for every board)."""

    dac_commands: tuple[tuple[int, int], ...] = ()  # (channel 1..15, value)
    control: tuple[int, ...] = ()  # values to apply as STATUS writes


def decode_rev8_write(words: Sequence[int], start_index: int, board_id: int | None) -> RtWrite:
    """Rev 8+: blocks of ``header, DAC x count-2, control`` for one board each.

    Header = (board id << 8) | count, count including header and control.
    Each quadlet is routed the way the firmware's address translator does
    (RTL reading, WriteAddressTranslation.v): a new block starts where the
    previous one ends, the board id is compared in header bits 11..8, the
    last quadlet of a block is the control word, and blocks for other boards
    are skipped. Any block write in MAIN space goes through it. A
    ``board_id`` of None takes every block.
    """
    dacs: list[tuple[int, int]] = []
    control: list[int] = []
    for owner, channel, value in _rev8_quadlets(words, start_index):
        if board_id is None or owner == board_id:
            if channel < 0:
                control.append(value)
            else:
                dacs.append((channel, value))
    return RtWrite(tuple(dacs), tuple(control))


def split_rev8_write(words: Sequence[int], start_index: int) -> dict[int, RtWrite]:
    """Every board's :func:`decode_rev8_write` of one block write, in one pass.

    Board ID -> its share; a board with no share is missing. The block chain
    does not depend on the board that follows it, so one walk serves them all:
    a broadcast carrying N boards' blocks is read once, not N times, and block
    by block (a slice each) rather than quadlet by quadlet. Where the translator
    would meet address 0 again inside a block (a chain reaching round its 8-bit
    address), the walk is left to :func:`_rev8_quadlets`.
    """
    shares: dict[int, RtWrite] = {}
    total = len(words)
    # Until the translator's address comes round to 0 no block has started.
    position = -start_index & 0xFF
    if position + total > _ADDRESS_SPAN:  # body slices are shorter than _CHANNEL_OF
        return _split_by_quadlet(words, start_index)
    while position < total:
        header = words[position]
        # A length of 0 reaches round the whole 8-bit address space.
        length = header & 0xFF or _ADDRESS_SPAN
        owner = (header >> 8) & 0xF
        last = position + length - 1
        dacs = tuple(zip(_CHANNEL_OF, words[position + 1 : min(last, total)], strict=False))
        control: tuple[int, ...] = (words[last],) if length > 1 and last < total else ()
        if dacs or control:
            # Mostly one block per board; a board named again gets the later ones after.
            earlier = shares.get(owner)
            if earlier is not None:
                dacs, control = earlier.dac_commands + dacs, earlier.control + control
            shares[owner] = RtWrite(dacs, control)
        position += length
    return shares


def _split_by_quadlet(words: Sequence[int], start_index: int) -> dict[int, RtWrite]:
    dacs: dict[int, list[tuple[int, int]]] = {}
    control: dict[int, list[int]] = {}
    for owner, channel, value in _rev8_quadlets(words, start_index):
        if channel < 0:
            control.setdefault(owner, []).append(value)
        else:
            dacs.setdefault(owner, []).append((channel, value))
    return _shares(dacs, control)


def _shares(
    dacs: dict[int, list[tuple[int, int]]], control: dict[int, list[int]]
) -> dict[int, RtWrite]:
    return {
        board: RtWrite(tuple(dacs.get(board, ())), tuple(control.get(board, ())))
        for board in dacs.keys() | control.keys()
    }


#: The translator's addresses: 8 bits.
_ADDRESS_SPAN = 0x100
#: The DAC channel of the n-th quadlet after a block header: the low 4 bits of n + 1.
_CHANNEL_OF = tuple((n + 1) & 0xF for n in range(_ADDRESS_SPAN))


def _rev8_quadlets(words: Sequence[int], start_index: int) -> Iterator[tuple[int, int, int]]:
    """(owner board, DAC channel or -1 for the control word, value) of every quadlet
    the address translator routes to a board; headers and words before the first
    block are nobody's."""
    block_start, block_length, owner = 0, 0, -1
    for position, value in enumerate(words):
        index = (start_index + position) & 0xFF  # the translator's 8-bit address
        if index in (block_start, (block_start + block_length) & 0xFF):
            block_start, block_length = index, value & 0xFF
            owner = (value >> 8) & 0xF
        elif owner < 0:
            continue
        elif index == (block_start + block_length - 1) & 0xFF:
            yield owner, -1, value
        else:
            yield owner, (index - block_start) & 0xF, value


def decode_rev7_write(words: Sequence[int], board_id: int | None) -> RtWrite:
    """Rev 7: groups of 4 DAC commands (board id in bits 27..24) and a control quadlet.

    A DAC command is taken only if it carries this board id; the control
    quadlet only if all four of its group did (RTL reading of the Rev 7
    FireWire.v; this is what lets one broadcast carry every board's group).
    """
    dacs: list[tuple[int, int]] = []
    control: list[int] = []
    group = CHANNELS + 1
    for first in range(0, len(words), group):
        chunk = words[first : first + group]
        mine = [
            board_id is None or (value >> DAC_BOARD_ID_SHIFT) & 0xF == board_id
            for value in chunk[:CHANNELS]
        ]
        dacs += [(n + 1, value) for n, value in enumerate(chunk[:CHANNELS]) if mine[n]]
        if len(chunk) == group and all(mine):
            control.append(chunk[CHANNELS])
    return RtWrite(tuple(dacs), tuple(control))


def decode_old_write(words: Sequence[int], board_id: int | None) -> RtWrite:
    """Firmware 1-6: groups of 4 DAC commands, channel 1 first, no control quadlet.

    As at Rev 7, a DAC command is taken only if it carries this board id in bits
    27..24 (None: every command). Inferred from the host, which tags every DAC
    command with the board id before Rev 8 and packs only the boards in use into
    a broadcast write, so a board can only find its group by the tag.
    """
    dacs: list[tuple[int, int]] = []
    for first in range(0, len(words), CHANNELS):
        for n, value in enumerate(words[first : first + CHANNELS]):
            if board_id is None or (value >> DAC_BOARD_ID_SHIFT) & 0xF == board_id:
                dacs.append((n + 1, value))
    return RtWrite(tuple(dacs))


def old_write_feeds_watchdog(write: RtWrite) -> bool:
    """Firmware < 7 only counts DAC commands with the valid bit as register writes.

    Inferred from the host, which adds a no-op write to feed the watchdog
    exactly when no DAC command of the block had its valid bit.
    """
    return any(value & DAC_VALID for _, value in write.dac_commands)
