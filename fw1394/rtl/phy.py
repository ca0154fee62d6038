"""The PHY on a link design's pins, for cocotb: delivers, grants, captures, checks.

It plays a 1394a PHY (``docs/rtl.md``, the interface facts in phy-link.md) on
the canonical signals of the harness wrapper (:mod:`fw1394.rtl.portmap`): one
``phy`` word it drives (drive flag, CTL, D) and one ``mon`` word it reads back
(the link's CTL/D and whether it drives, LREQ, busy, register-bus strobes).

Each clock cycle is one step: drive the PHY's value for the next rising edge,
wait for the falling edge, read what the link registered at the rising edge.
Every link request on LREQ is decoded; bus requests are granted, register
reads answered with a status transfer, register writes applied (IBR starts a
bus reset). What the link transmits after a grant is captured packet by packet.
Broken interface rules are collected in :attr:`Phy.violations`, one line each,
prefixed with a short signature.
"""

from __future__ import annotations

from collections import deque
from typing import Any, NamedTuple

from cocotb.triggers import FallingEdge, ValueChange

from fw1394.rtl.portmap import (
    MON_BLK_RD,
    MON_BLK_WR,
    MON_BUSY,
    MON_CTL,
    MON_FX_RD,
    MON_FX_WR,
    MON_LREQ,
    MON_OE,
    MON_RD,
    MON_WR,
)
from fw1394.rtl.regbus import RegisterServer

IDLE, STATUS, RECEIVE, GRANT = 0b00, 0b01, 0b10, 0b11
HOLD, TRANSMIT = 0b01, 0b10
#: Speeds by index (as ImmReq carries them, shifted right once): S100, S200, S400.
S100, S200, S400 = 0, 1, 2
#: The speed code the PHY puts on D after data-on, D0 first.
SPEED_CODES = (0x00, 0x40, 0x50)
#: Bits carried per SCLK cycle at each speed (D0-D1, D0-D3, D0-D7).
SPEED_BITS = (2, 4, 8)
#: Hold may last this many cycles at most (1394a).
MAX_HOLD = 47
#: Idle cycles a link may assert after a grant without Transmit (a null packet).
MAX_NULL_IDLE = 3
#: Cycles the PHY waits after a concatenation request before it grants again (the
#: minimum packet separation, data-end to the next data-prefix).
PACKET_SEPARATION = 8
#: Packets one concatenation chain may hold (ack, response, and then some).
MAX_CONCATENATED = 4
#: Request types on LREQ, and the bits after the type (the stop bit included).
REQUEST_BITS = {0: 4, 1: 4, 2: 4, 3: 4, 4: 5, 5: 13, 6: 2}
BUS_REQUESTS = {0: "ImmReq", 1: "IsoReq", 2: "PriReq", 3: "FairReq"}
#: A link granted the bus must start driving within this many cycles.
GRANT_TIMEOUT = 8
#: The gap count in this node's self-ID packet: the power-up value, the largest.
SELF_ID_GAP_COUNT = 0x3F  # not a node ID
#: The PHY drives the interface Idle (the word the model drives between events).
ON_IDLE = 1 << 10
#: What a run of the harness's runner waits for besides a cycle the model must see:
#: nothing (its words or cycles end), LREQ quiet, the link no longer busy.
UNTIL_END, UNTIL_QUIET, UNTIL_SETTLED = 0, 1, 2
#: Words the runner plays, and bytes it captures, in one run.
RUN_SLOTS = 64


class Limits(NamedTuple):
    """How long the PHY waits, in SCLK cycles (a port map's [phy] table)."""

    #: From the end of a received packet to the ack's first byte, at most.
    ack_gap: int = 32
    #: A link may stay busy after its answer (a 2 KiB write commit and more).
    busy: int = 20_000
    #: An owned interface may stay in use (the longest packet and then some).
    own: int = 80_000
    #: One packet, from its delivery to the end of its answer, in all.
    answer: int = 200_000


class Request(NamedTuple):
    """One decoded LREQ stream: its type and the bits after the type."""

    kind: int
    payload: int
    width: int


class Capture(NamedTuple):
    """What the link sent in one bus ownership."""

    packets: list[bytes]
    #: Cycles from the end of the received packet to the first transmitted byte.
    delay: int


class _Tenure(NamedTuple):
    packets: list[bytes]
    #: Cycles from the Grant to the first transmitted symbol (None: nothing sent).
    first_byte: int | None
    #: The link asked for the next packet to be concatenated (Hold, then Idle).
    concatenate: bool
    cycles: int


class _Run(NamedTuple):
    #: The ``mon`` word of the last cycle (observed as a step's).
    mon: int
    cycles: int
    #: LREQ quiet cycles after the last (for :data:`UNTIL_QUIET`).
    quiet: int
    #: D of the Transmit cycles before the last, when capturing.
    captured: list[int]


class Effect(NamedTuple):
    """A register access the design made: ``write`` or ``read``, its index and data."""

    kind: str
    address: int
    data: int | None


class Reply(NamedTuple):
    ack: int | None
    response: bytes | None
    concatenated: bool
    #: The register accesses made while the packet was received and answered.
    effects: list[Effect] = []


class Phy:
    """The PHY model on harness ``dut``; ``registers`` serves a register bus, if any."""

    def __init__(
        self,
        dut: Any,
        *,
        physical_id: int,
        limits: Limits,
        registers: RegisterServer | None,
        poll_reads: bool = False,
        release_visible: bool = True,
    ) -> None:
        self.dut = dut
        self.physical_id = physical_id
        self.limits = limits
        self.ack_gap = limits.ack_gap
        self.server = registers
        #: The pins show when the link lets go (not so with a PHY-drives flag).
        self.release_visible = release_visible
        #: PHY registers 0-15 (1394a base page), as a link reads them with RdReg.
        self.registers = [0] * 16
        self.registers[2] = 0xE2  # extended, two ports
        self.registers[3] = 0x40  # S400
        self.set_id()
        self.violations: list[str] = []
        self.requests: deque[Request] = deque()
        #: Every request decoded, kept for a refusal's account of what the PHY saw.
        self.seen: list[Request] = []
        #: Cycles in which the link drove CTL/D, and the CTL values it drove.
        self.driven = 0
        self.driven_ctl: set[int] = set()
        self.cycles = 0
        #: Register accesses since the last packet came.
        self.effects: list[Effect] = []
        self._drive = -1
        self._lreq_bits: list[int] | None = None
        self._lreq_need = 0
        self._rdata = 0
        #: The register bus has no read strobe: read data follows the address.
        self.poll_reads = poll_reads and registers is not None
        self._polled: int | None = None
        #: Cycles without events run inside the simulator (the harness's runner); a
        #: polled register bus needs a look at every cycle.
        self.runner = not self.poll_reads
        self._runs = 0

    def set_id(self) -> None:
        # Physical_ID, R (root), PS (cable power)
        self.registers[0] = (self.physical_id << 2) | 0b11

    # -- one clock cycle ----------------------------------------------------------------
    async def step(self, on: bool = True, ctl: int = IDLE, d: int = 0) -> int:
        """Drive (``on``, ``ctl``, ``d``) for the next edge; the link's ``mon`` word after it."""
        word = (on << 10) | (ctl << 8) | d
        if word != self._drive:
            self.dut.phy.value = word
            self._drive = word
        await FallingEdge(self.dut.sclk)
        self.cycles += 1
        value = self.dut.mon.value
        if value.is_resolvable:
            return self._observe(int(value.to_unsigned()), False, on)
        # X and Z read as 0; a link that drives them is told off.
        mon = int("".join(c if c in "01" else "0" for c in str(value)), 2)
        return self._observe(mon, True, on)

    def _observe(self, mon: int, undriven: bool, on: bool) -> int:
        """Judge and serve one cycle's ``mon`` word (``undriven``: it had X or Z bits)."""
        if mon >> MON_OE & 1:
            if undriven:
                self._violate("undriven-bits", "the link drives X or Z bits on CTL or D")
            self.driven += 1
            self.driven_ctl.add(mon >> MON_CTL & 3)
            if on:
                self._violate(
                    "contention", "the link drives CTL/D while the PHY owns the interface"
                )
        self._lreq(mon >> MON_LREQ & 1)
        if mon >> MON_RD & 0xF and self.server is not None:
            self._serve(mon)
        if mon >> MON_FX_WR & 3:
            self._effect(mon)
        if self.poll_reads:
            self._poll()
        return mon

    # -- many cycles at once ----------------------------------------------------------
    async def _run(
        self,
        words: list[int],
        *,
        hold: int = ON_IDLE,
        cycles: int = 0,
        until: int = UNTIL_END,
        capture: bool = False,
        quiet: tuple[int, int] = (0, 0),
    ) -> _Run:
        """Let the harness's runner drive ``words`` (or ``hold`` up to ``cycles``) and stop
        at the first cycle the model must see; that cycle is observed as a step is."""
        bits = self._lreq_bits
        need = 0
        if bits is not None and len(bits) >= 3:
            need = 3 + REQUEST_BITS.get(bits[0] << 2 | bits[1] << 1 | bits[2], 0)
        value = 0
        for bit in bits or ():
            value = value << 1 | bit
        self._runs = (self._runs + 1) & 0xFF
        count = len(words) if words else cycles
        command = (
            bool(words)
            | capture << 1
            | until << 2
            | (self.server is not None) << 4
            | hold << 5
            | count << 16
            | quiet[0] << 40
            | quiet[1] << 64
            | (bits is not None) << 80
            | len(bits or ()) << 81
            | value << 86
            | need << 102
            | self._runs << 107
        )
        dut = self.dut
        if words:
            dut.run_words.value = sum(word << 16 * k for k, word in enumerate(words))
        dut.run_cmd.value = command
        await ValueChange(dut.run_done)
        report = int(dut.run_report.value.to_unsigned())
        self._drive = -1
        ran = report >> 20 & 0xFFFFFF
        self.cycles += ran
        held = report >> 84 & 0x1F
        lq = report >> 68 & 0xFFFF
        for k in range(held - 1, -1, -1):
            self._lreq(lq >> k & 1)
        captured: list[int] = []
        taken = report >> 89 & 0x7F
        if taken:
            data = int(dut.run_capture.value.to_unsigned())
            captured = [data >> 8 * k & 0xFF for k in range(taken)]
            self.driven += taken
            self.driven_ctl.add(TRANSMIT)
        on = (words[ran - 1] if words else hold) >> 10 & 1
        mon = self._observe(report & 0x7FFFF, bool(report >> 19 & 1), bool(on))
        return _Run(mon, ran, report >> 44 & 0xFFFFFF, captured)

    async def play(self, words: list[int]) -> int:
        """Drive each of ``words`` (``on << 10 | ctl << 8 | d``) for one cycle, as
        stepping them would; the ``mon`` word after the last."""
        if not self.runner:
            mon = 0
            for word in words:
                mon = await self.step(bool(word >> 10 & 1), word >> 8 & 3, word & 0xFF)
            return mon
        mon = 0
        while words:
            run = await self._run(words[:RUN_SLOTS])
            mon, words = run.mon, words[run.cycles :]
        return mon

    async def hold(
        self, cycles: int, *, until: int = UNTIL_END, quiet: tuple[int, int] = (0, 0)
    ) -> _Run:
        """Hold the interface Idle at most ``cycles`` cycles; stop early at a cycle the
        model must look at or when ``until`` holds (:data:`UNTIL_QUIET`: LREQ quiet
        ``quiet[1]`` cycles, counting from ``quiet[0]``, and no request being
        received; :data:`UNTIL_SETTLED`: the link not busy and no request)."""
        if not self.runner:
            mon = await self.step()
            count = 0 if mon >> MON_LREQ & 1 else quiet[0] + 1
            return _Run(mon, 1, count, [])
        return await self._run([], cycles=cycles, until=until, quiet=quiet)

    def _effect(self, mon: int) -> None:
        address = _unsigned(self.dut.fx_addr.value)
        if mon >> MON_FX_WR & 1:
            self.effects.append(Effect("write", address, _unsigned(self.dut.fx_wdata.value)))
        if mon >> MON_FX_RD & 1:
            self.effects.append(Effect("read", address, None))

    def _poll(self) -> None:
        # Values change only at a new batch (the board's time) or with a write,
        # and both forget the last address, so one read per address change is enough.
        assert self.server is not None
        value = self.dut.reg_addr.value
        if not value.is_resolvable:
            return
        addr = value.to_unsigned()
        if addr != self._polled:
            self._polled = addr
            self._put(self.server.read(addr))

    def forget_read(self) -> None:
        """Read the register again even if the address stays (it may have changed)."""
        self._polled = None

    def _violate(self, signature: str, text: str) -> None:
        line = f"{signature}: {text}"
        if line not in self.violations:
            self.violations.append(line)

    def _serve(self, mon: int) -> None:
        server = self.server
        assert server is not None
        addr = self.dut.reg_addr.value.to_unsigned()
        if mon >> MON_RD & 1:
            self._put(server.read(addr))
        elif mon >> MON_BLK_RD & 1:
            self._put(server.block_read(addr, self.dut.reg_len.value.to_unsigned()))
        if mon >> MON_WR & 1:
            server.write(addr, self.dut.reg_wdata.value.to_unsigned())
            self._polled = None
        elif mon >> MON_BLK_WR & 1:
            length = self.dut.reg_len.value.to_unsigned()
            server.block_write(addr, self.dut.reg_wdata.value.to_unsigned(), length)
            self._polled = None

    def _put(self, value: int) -> None:
        if value != self._rdata:
            self.dut.reg_rdata.value = value
            self._rdata = value

    def _lreq(self, bit: int) -> None:
        bits = self._lreq_bits
        if bits is None:
            if bit:
                self._lreq_bits, self._lreq_need = [], 3
            return
        bits.append(bit)
        if len(bits) == 3:
            kind = bits[0] << 2 | bits[1] << 1 | bits[2]
            if kind not in REQUEST_BITS:
                self._violate("lreq-reserved", "a link request of reserved type 111")
                self._lreq_bits = None
                return
            self._lreq_need = 3 + REQUEST_BITS[kind]
        if len(bits) < self._lreq_need:
            return
        self._lreq_bits = None
        kind = bits[0] << 2 | bits[1] << 1 | bits[2]
        if bits[-1]:
            self._violate("lreq-stop", f"a link request (type {kind:03b}) without its stop bit")
            return
        payload = 0
        for b in bits[3:-1]:
            payload = payload << 1 | b
        request = Request(kind, payload, len(bits) - 4)
        self.requests.append(request)
        if len(self.seen) < 64:
            self.seen.append(request)

    @property
    def lreq_busy(self) -> bool:
        return self._lreq_bits is not None

    # -- what the PHY sends -------------------------------------------------------------
    async def idle(self, cycles: int) -> int:
        mon = 0
        while cycles > 0:
            run = await self.hold(cycles)
            mon, cycles = run.mon, cycles - run.cycles
        return mon

    async def status(self, bits: list[int]) -> None:
        """A status transfer: S0, S1, ... two bits a cycle on D0 and D1."""
        status = ON_IDLE | STATUS << 8
        words = [status | bits[k] << 7 | bits[k + 1] << 6 for k in range(0, len(bits), 2)]
        await self.play([*words, ON_IDLE])

    async def register_status(self, address: int, *, bus_reset: bool = False) -> None:
        value = self.registers[address]
        head = [0, 0, int(bus_reset), 0]
        await self.status(
            head
            + [address >> (3 - i) & 1 for i in range(4)]
            + [value >> (7 - i) & 1 for i in range(8)]
        )

    async def receive(self, raw: bytes, *, interrupting: int = 0, speed: int = S400) -> None:
        """Deliver a packet as the PHY does: data-on, speed code, bits, then Idle.

        ``speed``: S100 sends two bits a cycle on D0-D1, S200 four on D0-D3, S400
        a byte on D0-D7. ``interrupting``: first start a status transfer of
        register 0 and cut it after that many cycles, as a PHY does when a packet
        arrives meanwhile.
        """
        words = []
        if interrupting:
            value = self.registers[0]
            bits = [0] * 8 + [value >> (7 - i) & 1 for i in range(8)]
            status = ON_IDLE | STATUS << 8
            for k in range(0, min(2 * interrupting, 14), 2):
                words.append(status | bits[k] << 7 | bits[k + 1] << 6)
        receiving = ON_IDLE | RECEIVE << 8
        words += [receiving | 0xFF, receiving | 0xFF]
        if raw:
            words.append(receiving | SPEED_CODES[speed])
            if speed == S400:
                words += [receiving | byte for byte in raw]
            else:
                width = SPEED_BITS[speed]
                mask = (1 << width) - 1
                for byte in raw:
                    for shift in range(8 - width, -1, -width):
                        # The symbol on the top lines (D0 first), the rest low.
                        words.append(receiving | (byte >> shift & mask) << (8 - width))
        await self.play([*words, ON_IDLE])

    async def bus_reset(self) -> None:
        """Status with S2 and register 0, then this node's self-ID packet."""
        await self.register_status(0, bus_reset=True)
        self_id = (
            (0b10 << 30)
            | (self.physical_id << 24)
            | (1 << 22)
            | (SELF_ID_GAP_COUNT << 16)
            | (3 << 14)
        )
        await self.receive(self_id.to_bytes(4, "big") + (self_id ^ 0xFFFFFFFF).to_bytes(4, "big"))

    async def service(self) -> list[Capture]:
        """Answer the link's pending requests (register reads and writes, bus requests)."""
        captures = []
        while self.requests:
            request = self.requests.popleft()
            if request.kind in BUS_REQUESTS:
                captures.append(await self.grant(0, speed=_speed_of(request)))
            elif request.kind == 4:
                await self.register_status(request.payload & 0xF)
            elif request.kind == 5:
                address, value = request.payload >> 8 & 0xF, request.payload & 0xFF
                self.registers[address] = value & ~0x40 if address == 1 else value
                if address == 1 and value & 0x40:  # IBR
                    await self.bus_reset()
            # AccelCtl: nothing to do for a PHY without arbitration acceleration.
        return captures

    # -- what the link sends ------------------------------------------------------------
    async def grant(self, since_end: int, *, speed: int = S400) -> Capture:
        """Grant the bus and capture every packet the link sends until it lets go.

        A packet ended with Hold asks for concatenation: the PHY waits the
        minimum packet separation and grants again, and the next packet joins
        this capture (the response behind its ack_pending).
        """
        packets: list[bytes] = []
        first_byte: int | None = None
        cycles = 0
        for _ in range(MAX_CONCATENATED):
            tenure = await self._tenure(speed)
            if tenure.first_byte is not None and first_byte is None:
                first_byte = since_end + cycles + tenure.first_byte
            packets += tenure.packets
            cycles += tenure.cycles
            if not tenure.concatenate:
                break
            await self.idle(PACKET_SEPARATION - 2)  # the release and turnaround were the first
            cycles += PACKET_SEPARATION - 2
        return Capture(packets, first_byte if first_byte is not None else -1)

    async def _tenure(self, speed: int) -> _Tenure:
        """One Grant and what the link does with the interface until it gives it back."""
        step = self.step
        await step(True, GRANT, 0)
        await step(True, IDLE, 0)
        width = SPEED_BITS[speed]
        packets: list[bytes] = []
        current: bytearray | None = None
        symbol = symbols = 0
        # take: not driving yet; prefix: Idle/Hold before Transmit; data: Transmit;
        # end: the cycle after the data (Hold or Idle); close: the one more Idle.
        phase = "take"
        idles = hold = 0
        first_byte: int | None = None
        concatenate = False
        cycles = 2
        driving = False
        owned = 0
        while True:
            if owned >= self.limits.own:
                self._violate("ownership", f"the link kept the bus {self.limits.own} cycles")
                break
            if phase == "data" and self.runner:
                # The packet's Transmit cycles run inside the simulator, captured.
                run = await self._run([], hold=0, cycles=self.limits.own - owned, capture=True)
                mon = run.mon
                owned += run.cycles
                cycles += run.cycles
                for data in run.captured:
                    assert current is not None
                    symbol = symbol << width | data >> (8 - width)
                    symbols += width
                    if symbols == 8:
                        current.append(symbol)
                        symbol = symbols = 0
            else:
                mon = await step(False)
                owned += 1
                cycles += 1
            driving = bool(mon >> MON_OE & 1)
            if not driving:
                if phase == "take":
                    if cycles > GRANT_TIMEOUT:
                        break  # the link did not take the bus it asked for
                    continue
                if phase == "data":
                    self._violate("release", "the link let go of the interface without Idle")
                elif phase == "end":
                    self._violate(
                        "closing-idle",
                        "the link let go right after its packet, without the closing Idle",
                    )
                elif phase == "prefix" and hold:
                    self._violate("release", "the link let go after Hold without transmitting")
                break
            ctl = mon >> MON_CTL & 3
            if ctl == 0b11:
                self._violate("ctl-reserved", "the link drove the reserved CTL value 11")
                continue
            if phase == "end":
                if ctl == IDLE:
                    phase = "close"
                    break
                self._violate(
                    "no-grant",
                    "the link transmitted its next packet without waiting for the PHY's Grant"
                    if concatenate
                    else "the link went on transmitting after ending its packet with Idle",
                )
                # Capture it all the same: its contents are judged by the other oracles.
                concatenate = False
                phase, idles, hold = "prefix", 0, 0
            if phase in ("take", "prefix"):
                if ctl == IDLE:
                    idles += 1
                    phase = "prefix"
                    if idles > MAX_NULL_IDLE:
                        break  # a null packet (split-flag pins cannot show the release)
                    continue
                if ctl == HOLD:
                    hold += 1
                    phase = "prefix"
                    if hold == MAX_HOLD + 1:
                        self._violate("hold", f"Hold kept longer than {MAX_HOLD} cycles")
                    continue
                phase = "data"
                current = bytearray()
                symbol = symbols = 0
                if first_byte is None:
                    first_byte = cycles
            if phase == "data":
                assert current is not None
                if ctl == TRANSMIT:
                    symbol = symbol << width | (mon & 0xFF) >> (8 - width)
                    symbols += width
                    if symbols == 8:
                        current.append(symbol)
                        symbol = symbols = 0
                    continue
                packets.append(bytes(current))
                current = None
                concatenate = ctl == HOLD
                phase = "end"
        if current is not None:
            packets.append(bytes(current))
        if driving:
            # The link lets go after its closing Idle, and neither side drives for
            # one cycle (the turnaround) before the PHY does.
            for _ in range(2):
                mon = await step(False)
                cycles += 1
                if self.release_visible and mon >> MON_OE & 1:
                    self._violate("release", "the link still drove CTL/D after its closing Idle")
        return _Tenure(packets, first_byte, concatenate and phase in ("end", "close"), cycles)

    async def exchange(self, raw: bytes, *, interrupting: int = 0, speed: int = S400) -> Reply:
        """Deliver ``raw`` at ``speed`` and return the link's ack, response and tenure."""
        start = self.cycles
        await self._service_outside()
        self.effects = []
        if self.server is not None:
            self.server.new_packet()
            self.forget_read()
        await self.receive(raw, interrupting=interrupting, speed=speed)
        captures: list[Capture] = []
        # A request that starts after the ack gap cannot bring an ack inside it:
        # so much quiet on LREQ is silence.
        quiet = 0
        waited = 1  # the Idle that ended the packet
        while quiet < self.ack_gap or self.lreq_busy:
            if self.cycles - start > self.limits.answer:
                self._violate(
                    "timeout", f"no end to the answer {self.limits.answer} cycles after the packet"
                )
                break
            if self.requests:
                request = self.requests[0]
                if request.kind in BUS_REQUESTS:
                    self.requests.popleft()
                    captures.append(await self.grant(waited, speed=_speed_of(request)))
                    quiet = 0
                    if self._answered(captures):
                        break
                    continue
                await self.service()
                quiet = 0
                continue
            # Idle until a request, a cycle to look at, the silence, or the limit.
            left = self.limits.answer - (self.cycles - start) + 1
            run = await self.hold(left, until=UNTIL_QUIET, quiet=(quiet, self.ack_gap))
            waited += run.cycles
            quiet = run.quiet
        await self._settle()
        return self._reply(captures)._replace(effects=self.effects)

    def _answered(self, captures: list[Capture]) -> bool:
        packets = [p for c in captures for p in c.packets]
        if not packets:
            return False
        ack = packets[0]
        return len(ack) != 1 or ack[0] >> 4 != 0x2 or len(packets) > 1

    async def _settle(self) -> None:
        left = self.limits.busy
        while left > 0:
            # Pending requests are served after one cycle, as ever.
            run = await self.hold(1 if self.requests else left, until=UNTIL_SETTLED)
            left -= run.cycles
            if not run.mon >> MON_BUSY & 1 and not self.lreq_busy and not self.requests:
                return
            if self.requests:
                await self._service_outside()
        self._violate("busy", f"the link stayed busy {self.limits.busy} cycles after its answer")

    async def _service_outside(self) -> None:
        # Between answers the link has nothing to send: a packet now is an ack that
        # came after the silence was called, or a response nobody asked for.
        stray = [p for c in await self.service() for p in c.packets]
        if stray:
            self._violate(
                "unsolicited",
                f"the link sent {len(stray)} packet(s) outside any answer (an ack too late?)",
            )

    def _reply(self, captures: list[Capture]) -> Reply:
        if not captures or not any(c.packets for c in captures):
            return Reply(None, None, False)
        first = next(c for c in captures if c.packets)
        ack_packet = first.packets[0]
        if len(ack_packet) != 1:
            self._violate(
                "ack-size", f"the link's first packet is {len(ack_packet)} bytes, not an ack"
            )
            return Reply(None, ack_packet, False)
        code, parity = ack_packet[0] >> 4, ack_packet[0] & 0xF
        if parity != code ^ 0xF:
            self._violate("ack-parity", f"ack byte {ack_packet[0]:#04x} fails its parity")
        if first.delay > self.ack_gap:
            self._violate(
                "ack-gap",
                f"ack {first.delay} cycles after the packet, beyond the gap of {self.ack_gap}",
            )
        if len(first.packets) > 1:
            return Reply(code, first.packets[1], True)
        later = [p for c in captures[captures.index(first) + 1 :] for p in c.packets]
        return Reply(code, later[0] if later else None, False)


def _speed_of(request: Request) -> int:
    """The speed a bus request asks for (000 S100, 010 S200, 100 S400)."""
    return min(request.payload >> 1 & 3, S400)


def _unsigned(value: Any) -> int:
    """A signal's value, X and Z bits read as 0."""
    if value.is_resolvable:
        return int(value.to_unsigned())
    return int("".join(c if c in "01" else "0" for c in str(value)) or "0", 2)
