"""QLA1: a JHU FPGA1394 + QLA motor-controller board as an address space.

The personality answers what the JHU host library (Amp1394) asks during
start-up and in its real-time loop: the board registers, 4 motor channels,
the real-time read and write blocks of firmware revisions 1..9, the
watchdog, hub space and the CSR / configuration-ROM window. Offsets are
decoded like the firmware does, through the FireWire decoding of the register
map (:mod:`fw1394.boards.qla1.regmap`): bits 15..0 as a quadlet index, bits
11..8 ignored in the MAIN space, except in the CSR window 0xFFFF_F000_0xxx,
which is byte-addressed. Unmapped reads
return 0 and writes there vanish: like the real board, this one never
refuses a request (only offsets beyond 48 bits and values beyond 32 bits,
which no packet can carry, raise).

``defects`` plants deliberate misbehaviours for negative tests and the
fuzzer; the names this board acts on are in :data:`BOARD_DEFECTS`, other
names are left for the layers that receive the same set.
"""

from __future__ import annotations

import functools
import operator
import struct
from collections.abc import Callable, Mapping, Sequence

from fw1394.boards.qla1 import rt_blocks as rt
from fw1394.boards.qla1.channels import MotorChannel
from fw1394.boards.qla1.config_rom import CSR_BYTE_MASK, CsrSpace, build_config_rom, in_csr_window
from fw1394.boards.qla1.dallas import BUFFER_BASE as DALLAS_BUFFER_BASE
from fw1394.boards.qla1.dallas import FIRST_FIRMWARE as DALLAS_FIRST_FIRMWARE
from fw1394.boards.qla1.dallas import Ds2505
from fw1394.boards.qla1.eth_phy import MdioWindow, mdio_channel
from fw1394.boards.qla1.eth_switch import FIRST_FIRMWARE as SWITCH_FIRST_FIRMWARE
from fw1394.boards.qla1.eth_switch import switch_data, switch_index
from fw1394.boards.qla1.hub import HubBlock, HubState, reporting_board
from fw1394.boards.qla1.phy_window import PhyInterface
from fw1394.boards.qla1.prom import ConfigProm, qla_prom_with_serial, with_fpga_serial
from fw1394.boards.qla1.regmap import FIREWIRE_DECODING
from fw1394.boards.qla1.regs import (
    BLOCK_INDEX_MASK,
    CHANNELS,
    ETH_STATUS_BY_FPGA_VERSION,
    HUB_MEMORY_BASE,
    HUB_QUERY,
    IP_UNASSIGNED,
    MAX_BOARD_ID,
    OLD_QUERY_LAST_FIRMWARE,
    OLD_QUERY_OFFSET,
    PROM_BUFFER_BASE,
    QLA1_HARDWARE_VERSION,
    QLA_PROM_BUFFER,
    QLA_PROM_COMMAND,
    QLA_PROM_RESULT,
    SPACE_SHIFT,
    BoardRegister,
    ChannelRegister,
    Space,
    ip_to_register,
)
from fw1394.boards.qla1.status import BoardControl
from fw1394.boards.qla1.watchdog import Watchdog
from fw1394.engine.space import AddressError, DataError
from fw1394.packets.nodeid import phy_of

#: STATUS writes are stored and read back verbatim (breaks the board id).
DEFECT_STATUS_WRITE_STORED = "status-write-stored"
#: The watchdog never times out.
DEFECT_WATCHDOG_DISABLED = "watchdog-disabled"
#: Real-time block writes are applied whatever board id they carry.
DEFECT_RT_WRITE_ANY_BOARD = "rt-write-any-board"
#: HARDWARE_VERSION reads byte-swapped ('1ALQ'), as a little-endian slip would.
DEFECT_HW_VERSION_SWAPPED = "hw-version-swapped"
#: Unmapped offsets raise AddressError instead of reading 0.
DEFECT_UNMAPPED_ADDRESS_ERROR = "unmapped-address-error"
BOARD_DEFECTS = frozenset(
    {
        DEFECT_STATUS_WRITE_STORED,
        DEFECT_WATCHDOG_DISABLED,
        DEFECT_RT_WRITE_ANY_BOARD,
        DEFECT_HW_VERSION_SWAPPED,
        DEFECT_UNMAPPED_ADDRESS_ERROR,
    }
)

OFFSET_LIMIT = 1 << 48
#: The register-bus address of an offset (decoded once per offset: they repeat).
_register_address = functools.lru_cache(maxsize=4096)(FIREWIRE_DECODING.address)
#: Two amplifier temperatures (bits 15..8 and 7..0) in the board's raw units.
TEMPERATURE_READING = 0x3C3C
#: QTR1, QTR5 and the running counter of every channel: a stalled encoder has no edges.
_NO_EDGES = (0,) * CHANNELS
#: What a channel adds to the real-time block's inputs (see Qla1Board._sample_inputs).
_COMMAND_AND_POSITION = operator.attrgetter("dac_command", "encoder_position")


class Qla1Board:
    """One QLA board (hardware version 'QLA1') on the virtual bus."""

    def __init__(
        self,
        *,
        board_id: int,
        firmware: int = 8,
        fpga_version: int = 3,
        ip_address: str | None = None,
        defects: frozenset[str] = frozenset(),
        git_description: int = 0,
        physical_id: int = 0,
    ) -> None:
        if not 0 <= board_id <= MAX_BOARD_ID:
            raise ValueError(f"board_id: {board_id} is not 0..{MAX_BOARD_ID}")
        if firmware < 1:
            raise ValueError(f"firmware: {firmware} is not a firmware revision (1 or more)")
        if fpga_version not in ETH_STATUS_BY_FPGA_VERSION:
            raise ValueError(f"fpga_version: {fpga_version} is not 1, 2 or 3")
        self.board_id = board_id
        self.firmware = firmware
        self.fpga_version = fpga_version
        self.defects = frozenset(defects)
        self.git_description = git_description & 0xFFFFFFFF
        self._initial_ip = IP_UNASSIGNED if ip_address is None else ip_to_register(ip_address)
        #: The inputs and the block after its timestamp of the last sample (see _rt_block).
        self._last_sample: tuple[tuple[object, ...], tuple[int, ...]] | None = None
        self._node_id = phy_of(physical_id)
        self._now = 0
        # The PROMs keep their contents through a reboot.
        self.prom = with_fpga_serial(ConfigProm(), f"FPGA 1394-{board_id:02d}")
        self.qla_prom = qla_prom_with_serial(f"QLA 1394-{board_id:02d}")
        # The instrument's 1-wire memory (an instrument stays plugged in through a reboot).
        self.dallas = Ds2505()
        # FPGA V3's two Ethernet PHYs, by channel (1, 2); the chips outlive a reboot too.
        self.mdio = {channel: MdioWindow() for channel in (1, 2)} if fpga_version == 3 else {}
        self._power_up()
        # Readers look attributes up on each call, so they survive a reboot's fresh state.
        self._board_readers = self._board_register_readers()

    def _power_up(self) -> None:
        """Everything a reboot puts back (the clock keeps running)."""
        self.control = BoardControl()
        self.watchdog = Watchdog(last_clear_tick=self._now)
        self.channels = [MotorChannel(number, self.firmware) for number in range(1, CHANNELS + 1)]
        self.phy = PhyInterface(node_id=self._node_id)
        self.hub = HubState(self.board_id, self.firmware)
        has_ethernet = self.fpga_version >= 2
        self.csr = CsrSpace(build_config_rom(self.board_id, self.firmware, has_ethernet))
        self.csr.node_id = self._node_id
        self.ip_register = self._initial_ip
        self._stored_status: int | None = None
        self._rt_reference_tick = self._now

    # -- things outside the AddressSpace protocol ---------------------------------------

    @property
    def now(self) -> int:
        """The board's clock, in 49.152 MHz ticks."""
        return self._now

    @property
    def rt_read_quadlets(self) -> int:
        return rt.rt_read_quadlets(self.firmware)

    @property
    def rt_write_quadlets(self) -> int:
        return rt.rt_write_quadlets(self.firmware)

    def set_physical_id(self, physical_id: int) -> None:
        """The node number the bus gave this node (PHY register 0, CSR NODE_IDS)."""
        self._node_id = phy_of(physical_id)
        self.phy.node_id = self._node_id
        self.csr.node_id = self._node_id

    def broadcast_read_data(self) -> bytes | None:
        """Hub memory once every queried board has reported, else None.

        In Ethernet-only mode this is the data the hub board sends the host
        unasked after a broadcast query (as a block read response).
        """
        if not self.hub.complete:
            return None
        return _quadlets_to_bytes(self.hub.image(self._now))

    def store_hub_broadcast(self, words: Sequence[int]) -> None:
        """Another board's block, written to hub memory (a register write: feeds the watchdog)."""
        self.watchdog.clear_count(self._now)
        self.hub.store_broadcast(words, self._now)

    def store_hub_blocks(self, blocks: Sequence[HubBlock]) -> None:
        """Other boards' blocks of this round, as :meth:`store_hub_broadcast` stores their
        broadcasts, taken from their hubs instead of unpacked from the broadcasts."""
        self.keep_hub_blocks([(reporting_board(block.quadlets), block) for block in blocks])

    def keep_hub_blocks(self, blocks: Sequence[tuple[int, HubBlock]]) -> None:
        """:meth:`store_hub_blocks` of blocks whose reporting board is known already
        (a rack works it out once per block, not once per block and hub)."""
        if blocks:
            self.watchdog.clear_count(self._now)
            self.hub.keep_all(blocks, self._now)

    def keep_hub_round(self, round_blocks: Mapping[int, HubBlock]) -> None:
        """:meth:`keep_hub_blocks` of the other boards' blocks of a round this board's
        query has just started, at the query's tick, all at once (see
        :meth:`HubState.keep_round`). The query restarted the watchdog count at this
        tick already: the blocks' writes leave it as it is."""
        self.hub.keep_round(round_blocks, self._now)

    # -- AddressSpace -------------------------------------------------------------------

    def set_time(self, ticks: int) -> None:
        if ticks < self._now:
            raise ValueError(f"ticks: {ticks} is before the board's time {self._now}")
        self._tick(ticks)

    def _tick(self, ticks: int) -> None:
        """The clock moves on to ``ticks`` (not before the board's time)."""
        self._now = ticks
        if DEFECT_WATCHDOG_DISABLED not in self.defects and self.watchdog.advance(ticks):
            self.control.disable_all_amps()

    def advance_to(self, ticks: int) -> None:
        """:meth:`set_time` unless ``ticks`` is not after the board's time (then nothing)."""
        if ticks > self._now:
            self._tick(ticks)

    def read_quadlet(self, offset: int) -> int:
        _check_offset(offset)
        if in_csr_window(offset):
            return self.csr.read(offset & CSR_BYTE_MASK)
        return self._read_index(_register_address(offset))

    def write_quadlet(self, offset: int, value: int) -> None:
        _check_offset(offset)
        if not 0 <= value <= 0xFFFFFFFF:
            raise DataError(f"value: {value:#x} does not fit in a quadlet")
        self.watchdog.clear_count(self._now)
        if in_csr_window(offset):
            self.csr.write(offset & CSR_BYTE_MASK, value)
            return
        if offset == OLD_QUERY_OFFSET and self.firmware <= OLD_QUERY_LAST_FIRMWARE:
            self._broadcast_query(value)
            return
        self._write_index(_register_address(offset), value)

    def take_query(self, value: int) -> None:
        """A broadcast query: :meth:`write_quadlet` of ``value`` to 0x1800, without decoding
        the offset again (the rack serves the host's query to every board at once)."""
        self.watchdog.clear_count(self._now)
        self._broadcast_query(value)

    def read_block(self, offset: int, length: int) -> bytes:
        _check_offset(offset)
        if length < 0:
            raise DataError(f"length: {length} is negative")
        count = -(-length // 4)
        if in_csr_window(offset):
            start = offset & CSR_BYTE_MASK
            words = [self.csr.read((start + 4 * n) & CSR_BYTE_MASK) for n in range(count)]
        elif _space(_register_address(offset)) == Space.MAIN:
            words = self._rt_block_read(_register_address(offset), count)
        elif _space(_register_address(offset)) == Space.HUB:
            # Hub memory is laid out once per read, not once per quadlet; a read that
            # does not wrap within the space is a run of indices (hub space decodes
            # every index as itself), sliced at once.
            first = _register_address(offset)
            if (first & BLOCK_INDEX_MASK) + count <= BLOCK_INDEX_MASK + 1:
                words = self.hub.read_run(first, count, self._now)
            else:
                words = self.hub.read_registers(self._block_indices(offset, count), self._now)
        else:
            words = [self._read_index(index) for index in self._block_indices(offset, count)]
        return _quadlets_to_bytes(words)[:length]

    def write_block(self, offset: int, data: bytes) -> None:
        _check_offset(offset)
        # Only whole quadlets reach the registers, as in the firmware.
        count = len(data) // 4
        words = list(struct.unpack_from(f">{count}I", data)) if count else []
        if not words:
            return
        if in_csr_window(offset):
            self.watchdog.clear_count(self._now)
            start = offset & CSR_BYTE_MASK
            for n, value in enumerate(words):
                self.csr.write((start + 4 * n) & CSR_BYTE_MASK, value)
            return
        index = _register_address(offset)
        space = _space(index)
        if space == Space.MAIN:
            self._rt_block_write(index, words)
            return
        if space == Space.HUB and index == HUB_MEMORY_BASE:
            self.store_hub_broadcast(words)
            return
        if space == Space.PROM and index == PROM_BUFFER_BASE:
            self.watchdog.clear_count(self._now)
            self.prom.program(words, self._now)
            return
        self.watchdog.clear_count(self._now)
        for target, value in zip(self._block_indices(offset, len(words)), words, strict=True):
            self._write_index(target, value)

    # -- decoding -----------------------------------------------------------------------

    @staticmethod
    def _block_indices(offset: int, count: int) -> list[int]:
        # Block transfers step bits 11..0 and keep the space nibble (they wrap within
        # it); each step is decoded again, so MAIN-space steps alias like single reads.
        index = _register_address(offset)
        space_bits = index & ~BLOCK_INDEX_MASK
        return [
            _register_address(space_bits | ((index + n) & BLOCK_INDEX_MASK)) for n in range(count)
        ]

    def _unmapped(self, index: int) -> int:
        if DEFECT_UNMAPPED_ADDRESS_ERROR in self.defects:
            raise AddressError(f"offset: nothing at quadlet index {index:#06x}")
        return 0

    def _read_index(self, index: int) -> int:
        space = _space(index)
        if space == Space.MAIN:
            return self._read_main(index)
        if space == Space.HUB:
            return self.hub.read_register(index, self._now)
        if space == Space.PROM:
            return self.prom.buffer_read(index - PROM_BUFFER_BASE)
        if space == Space.PROM_QLA:
            if index == QLA_PROM_RESULT:
                return self.qla_prom.result
            return self.qla_prom.buffer_read(index - QLA_PROM_BUFFER)
        if space == Space.ETH and (window := self.mdio.get(mdio_channel(index) or 0)):
            return window.read()
        if space == Space.ETH and self.mdio and self.firmware >= SWITCH_FIRST_FIRMWARE:
            position = switch_index(index)
            if position is not None:
                return switch_data(position)
        if space == Space.DALLAS and self.firmware >= DALLAS_FIRST_FIRMWARE:
            return self.dallas.buffer_read(index - DALLAS_BUFFER_BASE)
        return self._unmapped(index)

    def _write_index(self, index: int, value: int) -> None:
        space = _space(index)
        if space == Space.MAIN:
            self._write_main(index, value)
        elif space == Space.HUB and index == HUB_QUERY:
            self._broadcast_query(value)
        elif space == Space.ETH and (window := self.mdio.get(mdio_channel(index) or 0)):
            window.write(value)
        elif space == Space.PROM_QLA:
            if index == QLA_PROM_COMMAND:
                self.qla_prom.command(value)
            else:
                self.qla_prom.buffer_write(index - QLA_PROM_BUFFER, value)
        # Other spaces (Ethernet debug, data buffer...) are not modelled: writes vanish.

    def _read_main(self, index: int) -> int:
        channel, register = (index >> 4) & 0xF, index & 0xF
        if channel > CHANNELS:
            return self._unmapped(index)
        if channel == 0:
            return self._read_board_register(register)
        return self.channels[channel - 1].read(register, self.control.amp_on(channel))

    def _write_main(self, index: int, value: int) -> None:
        channel, register = (index >> 4) & 0xF, index & 0xF
        if channel > CHANNELS:
            return
        if channel == 0:
            self._write_board_register(register, value)
            return
        enable = self.channels[channel - 1].write(register, value)
        if enable is not None:
            self.control.request_amp(channel, enable)

    # -- board registers ----------------------------------------------------------------

    def _status(self) -> int:
        if self._stored_status is not None:
            return self._stored_status
        return self.control.status(self.board_id, self.watchdog.timed_out)

    def _board_register_readers(self) -> dict[int, Callable[[], int]]:
        return {
            BoardRegister.STATUS: self._status,
            BoardRegister.FW_PHY_REQ: lambda: self.phy.request,
            BoardRegister.FW_PHY_RESP: lambda: self.phy.response,
            BoardRegister.WATCHDOG: lambda: self.watchdog.register_value(),
            BoardRegister.HARDWARE_VERSION: self._hardware_version,
            BoardRegister.TEMPERATURE: lambda: TEMPERATURE_READING,
            BoardRegister.DIGITAL_OUTPUT: lambda: self.control.digital_outputs,
            BoardRegister.FIRMWARE_VERSION: lambda: self.firmware,
            BoardRegister.DIGITAL_INPUT: lambda: self.control.digital_input(),
            BoardRegister.IP_ADDRESS: self._ip_register_value,
            BoardRegister.ETH_STATUS: lambda: ETH_STATUS_BY_FPGA_VERSION[self.fpga_version],
            BoardRegister.PROM_STATUS: self.prom.interface_status,
            BoardRegister.PROM_RESULT: lambda: self.prom.result,
            BoardRegister.DALLAS_STATUS: self._dallas_status,
            BoardRegister.GIT_DESCRIPTION: lambda: self.git_description,
        }

    def _read_board_register(self, register: int) -> int:
        reader = self._board_readers.get(register)
        # The I/O-expander interface is not modelled: it reads as idle (0).
        return reader() if reader is not None else 0

    def _dallas_status(self) -> int:
        return self.dallas.status() if self.firmware >= DALLAS_FIRST_FIRMWARE else 0

    def _hardware_version(self) -> int:
        if DEFECT_HW_VERSION_SWAPPED in self.defects:
            return int.from_bytes(QLA1_HARDWARE_VERSION.to_bytes(4, "big"), "little")
        return QLA1_HARDWARE_VERSION

    def _ip_register_value(self) -> int:
        # FPGA V1 has no Ethernet, hence no IP register.
        return self.ip_register if self.fpga_version >= 2 else 0

    def _write_board_register(self, register: int, value: int) -> None:
        if register == BoardRegister.STATUS:
            self._write_status(value)
        elif register == BoardRegister.FW_PHY_REQ:
            self.phy.write_request(value)
        elif register == BoardRegister.PROM_STATUS:
            self.prom.command(value, self._now)
        elif register == BoardRegister.DALLAS_STATUS and self.firmware >= DALLAS_FIRST_FIRMWARE:
            self.dallas.control(value)
        elif register == BoardRegister.FW_PHY_RESP:
            self.phy.write_response(value)
        elif register == BoardRegister.WATCHDOG:
            self.watchdog.write_register(value)
        elif register == BoardRegister.DIGITAL_OUTPUT:
            self.control.write_digital_outputs(value)
        elif register == BoardRegister.IP_ADDRESS and self.fpga_version >= 2:
            self.ip_register = self._ip_with_board_id(value)
        # ETH_STATUS control bits (clear errors, PHY reset...) have nothing to act on here.

    def _ip_with_board_id(self, value: int) -> int:
        # Firmware 9 gives each board its own address: board id added to the last octet.
        if self.firmware < 9 or value == IP_UNASSIGNED:
            return value
        last_octet = ((value >> 24) + self.board_id) & 0xFF
        return (value & 0x00FFFFFF) | last_octet << 24

    def _write_status(self, value: int) -> None:
        if DEFECT_STATUS_WRITE_STORED in self.defects:
            self._stored_status = value
        command = self.control.command(value)
        if command.asks_for_power:
            self.watchdog.acknowledge(self._now)
        if command.reboot:
            self._power_up()
            return
        # While the timeout flag is up, the firmware keeps every amplifier disabled.
        if self.watchdog.timed_out:
            self.control.disable_all_amps()

    # -- real-time blocks and hub ---------------------------------------------------------

    def _take_timestamp(self) -> int:
        """Ticks since the previous real-time read or broadcast query, minus 1."""
        elapsed = self._now - self._rt_reference_tick
        self._rt_reference_tick = self._now
        return (max(elapsed, 1) - 1) & 0xFFFFFFFF

    def _rt_block(self) -> tuple[int, ...]:
        """The real-time block, sampled now.

        Only the timestamp changes from one sample to the next unless one of the
        values in :meth:`_sample_inputs` does (the host's loop samples every board
        every cycle, mostly with nothing changed in between): the rest of the last
        sample is kept with the values it was made from, and made again when they
        differ.
        """
        inputs = self._sample_inputs()
        timestamp = self._take_timestamp()
        last = self._last_sample
        if last is None or last[0] != inputs:
            last = self._last_sample = (inputs, self._sample_tail())
        return (timestamp, *last[1])

    def _sample_inputs(self) -> tuple[object, ...]:
        """Every value the block after its timestamp is made from."""
        control, channels = self.control, self.channels
        return (
            self._stored_status,
            self.watchdog.timed_out,
            control.relay_on,
            control.power_enable,
            control.amps_disabled,
            control.digital_outputs,
            [*map(_COMMAND_AND_POSITION, channels)],
        )

    def _sample_tail(self) -> tuple[int, ...]:
        """The real-time block after its timestamp, made from the board's state."""
        channels = self.channels
        on = self.control.amps_on
        amp_on = [bool(on >> (channel.number - 1) & 1) for channel in channels]
        sample = rt.RtSample(
            timestamp=0,
            status=self._status(),
            digital_input=self.control.digital_input(),
            # Bits 31..16 of the temperature quadlet carry data-collection status: idle.
            temperature=TEMPERATURE_READING,
            adc=[channel.adc(amp) for channel, amp in zip(channels, amp_on, strict=True)],
            encoder_position=[channel.encoder_data() for channel in channels],
            encoder_period=[channel.encoder_period() for channel in channels],
            encoder_qtr1=_NO_EDGES,
            encoder_qtr5=_NO_EDGES,
            encoder_running=_NO_EDGES,
            motor_status=[MotorChannel.motor_status(amp) for amp in amp_on],
        )
        return tuple(rt.rt_read_block(sample, self.firmware)[1:])

    def _rt_block_read(self, index: int, count: int) -> list[int]:
        block = self._rt_block()
        words = []
        for target in self._block_indices(index, count):
            # A MAIN-space block read indexes the real-time block with offset bits 5..0.
            position = target & rt.RT_INDEX_MASK
            words.append(block[position] if position < len(block) else 0)
        return words

    def _rt_block_write(self, index: int, words: list[int]) -> None:
        board = None if DEFECT_RT_WRITE_ANY_BOARD in self.defects else self.board_id
        if self.firmware >= 8:
            write = rt.decode_rev8_write(words, index, board)
        elif self.firmware == 7:
            write = rt.decode_rev7_write(words, board)
        else:
            write = rt.decode_old_write(words, board)
        self.apply_rt_write(write)

    def apply_rt_write(self, write: rt.RtWrite) -> None:
        """Carry out this board's share of a real-time block write (decoded already)."""
        if self.firmware < 7:
            feeds = rt.old_write_feeds_watchdog(write)
        else:
            feeds = bool(write.dac_commands or write.control)
        if feeds:
            self.watchdog.clear_count(self._now)
        channels = self.channels
        for channel, value in write.dac_commands:
            if 1 <= channel <= CHANNELS:  # straight to the channel: the common case
                enable = channels[channel - 1].write_dac(value)
                if enable is not None:
                    self.control.request_amp(channel, enable)
            else:
                # The translator aims at register DAC of that channel, whatever it is.
                self._write_main((channel << 4) | ChannelRegister.DAC, value)
        for value in write.control:
            self._write_status(value)

    def _broadcast_query(self, value: int) -> None:
        hub, now = self.hub, self._now
        hub.query(value, now)
        if hub.wants(self.board_id):
            hub.store(self.board_id, hub.sequence, self._rt_block(), now)
        else:
            self._take_timestamp()


def _check_offset(offset: int) -> None:
    if not 0 <= offset < OFFSET_LIMIT:
        raise AddressError(f"offset: {offset:#x} is not a 48-bit 1394 offset")


def _space(index: int) -> int:
    return index >> SPACE_SHIFT


def _quadlets_to_bytes(words: list[int]) -> bytes:
    return struct.pack(f">{len(words)}I", *words)
