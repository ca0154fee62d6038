"""The simulation side of an RTL target: a cocotb test that serves packets from a socket.

The simulator (vvp with cocotb) runs this module's one test. It connects back
to the process that started it (:mod:`fw1394.rtl.simulation`), resets the
design, lets it learn its node ID, checks that it acknowledges a valid read,
and then answers requests, one JSON line each, until told to stop. While it
waits for a request the simulation does not advance.
"""

from __future__ import annotations

import json
import os
import socket
from typing import Any

import cocotb
from cocotb.triggers import Timer

from fw1394.boards.registry import make_board
from fw1394.packets import QuadletReadRequest
from fw1394.packets.asynchronous import encode_async
from fw1394.packets.nodeid import node_id
from fw1394.rtl.phy import BUS_REQUESTS, S400, Limits, Phy
from fw1394.rtl.portmap import load
from fw1394.rtl.regbus import RegisterServer

#: SCLK of a 1394a PHY, MHz (a port map or campaign may run the design at another).
SCLK_MHZ = 49.152
RESET_CYCLES = 4
SETTLE_CYCLES = 48
CONFIG_VARIABLE = "FW1394_RTL_CONFIG"


class Node:
    """The design under test with the PHY model and, if any, the board behind its bus."""

    def __init__(self, dut: Any, config: dict[str, Any]) -> None:
        self.dut = dut
        self.config = config
        self.portmap = load(config["portmap"])
        self.phy: Phy | None = None
        #: What the PHY saw of the design during reset and the check read (for a refusal).
        self.probe: dict[str, Any] = {}
        #: The pins the harness drives, as the design saw them at time 0.
        self.time_zero: dict[str, str] = {}

    def read_time_zero(self) -> None:
        """Keep the values of the pins the harness drives, as the design sees them."""
        dut, portmap = self.dut, self.portmap
        seen = {"phy drives": str(dut.phy_on.value), "reset": str(dut.rst.value)}
        if portmap.reset_active_low:
            seen["reset"] = {"0": "1", "1": "0"}.get(seen["reset"], seen["reset"])
        for role, signal in (("ctl", ("ctl_in", "ctl_pins")), ("d", ("d_in", "d_pins"))):
            for name in signal:
                handle = getattr(dut, name, None)
                if handle is not None:
                    seen[role] = str(handle.value)
                    break
        pins = portmap.pins
        named = {
            "phy drives": pins.get("phy_drives", ""),
            "reset": portmap.reset,
            "ctl": pins.get("ctl_in", pins.get("ctl", "")),
            "d": pins.get("d_in", pins.get("d", "")),
        }
        self.time_zero = {
            named[k] or k: v for k, v in seen.items() if named[k] or k != "phy drives"
        }

    async def start(self, *, check: bool = True) -> bool:
        """Reset the design, give it its node ID; whether it acks a valid read."""
        config = self.config
        server = None
        if self.portmap.served and self.portmap.model is not None:
            space = make_board(
                self.portmap.model,
                board_id=config["board_id"],
                defects=frozenset(config["defects"]),
            )
            server = RegisterServer(space, byte_addressed=self.portmap.model == "memory")
        phy = self.phy = Phy(
            self.dut,
            physical_id=config["physical_id"],
            limits=Limits(
                ack_gap=self.portmap.ack_gap,
                busy=self.portmap.busy_cycles,
                own=self.portmap.own_cycles,
                answer=self.portmap.answer_cycles,
            ),
            registers=server,
            poll_reads="rd" not in self.portmap.registers,
            release_visible=self.portmap.style != "split-flag",
        )
        if config.get("every_cycle"):
            phy.runner = False
        # The model starts from read data 0, as the harness does at time 0: a restart
        # must not leave the last campaign's value on the bus.
        self.dut.reg_rdata.value = 0
        self.dut.rst.value = 1
        await phy.idle(RESET_CYCLES)
        in_reset = phy.driven + len(phy.seen)
        self.dut.rst.value = 0
        await phy.idle(RESET_CYCLES)
        await phy.bus_reset()
        await self._settle()
        if not check:
            return True
        probe = QuadletReadRequest(
            destination_id=node_id(config["physical_id"]),
            tlabel=0,
            source_id=node_id(1 if config["physical_id"] != 1 else 2),
            offset=config.get("check_offset", 0),
        )
        reply = await phy.exchange(encode_async(probe))
        self.probe = {
            "requests": [[r.kind, r.payload, r.width] for r in phy.seen],
            "driven": phy.driven,
            # Activity while the harness held reset, and none after: reset inverted.
            "active_in_reset_only": in_reset > 0 and phy.driven + len(phy.seen) == in_reset,
            "driven_ctl": sorted(phy.driven_ctl),
            "violations": list(phy.violations),
            "ack": reply.ack,
            "granted": any(r.kind in BUS_REQUESTS for r in phy.seen),
            "time_zero": self.time_zero,
        }
        phy.violations.clear()
        return reply.ack is not None

    async def _settle(self) -> None:
        """Idle while the link takes in the bus reset, serving what it asks for."""
        phy = self.phy
        assert phy is not None
        left = SETTLE_CYCLES
        while left > 0:
            left -= (await phy.hold(left)).cycles
            await phy.service()

    async def renumber(self, physical_id: int) -> None:
        """A bus reset after which this node has ``physical_id``."""
        phy = self.phy
        assert phy is not None
        phy.physical_id = physical_id
        phy.set_id()
        await phy.bus_reset()
        await self._settle()

    async def exchange(
        self, now: float, packets: list[str], interrupting: int = 0, speeds: list[int] | None = None
    ) -> dict[str, Any]:
        phy = self.phy
        assert phy is not None
        if phy.server is not None:
            phy.server.set_time(now)
        replies = []
        effects = []
        # Which packet's exchange each violation came in (its kind names the finding);
        # one left from before the batch goes to its first packet.
        blamed = [0] * len(phy.violations)
        for k, text in enumerate(packets):
            speed = speeds[k] if speeds else S400
            before = len(phy.violations)
            reply = await phy.exchange(bytes.fromhex(text), interrupting=interrupting, speed=speed)
            blamed += [k] * (len(phy.violations) - before)
            replies.append(
                [
                    reply.ack,
                    None if reply.response is None else reply.response.hex(),
                    reply.concatenated,
                ]
            )
            effects.append([list(effect) for effect in reply.effects])
        violations, phy.violations = phy.violations, []
        return {
            "replies": replies,
            "effects": effects,
            "violations": violations,
            "blamed": blamed,
            "cycles": phy.cycles,
        }


def start_clock(dut: Any, mhz: float) -> None:
    """Start the harness's SCLK at ``mhz`` (it runs inside the simulator)."""
    dut.sclk_half_ps.value = round(1e6 / (2 * mhz))


@cocotb.test()
async def serve(dut: Any) -> None:
    """Answer the parent's requests until it says stop or goes away."""
    config = json.loads(os.environ[CONFIG_VARIABLE])
    start_clock(dut, config.get("sclk_mhz", SCLK_MHZ))
    sock = socket.create_connection(("127.0.0.1", config["port"]))
    stream = sock.makefile("rwb")
    node = Node(dut, config)

    def send(message: dict[str, Any]) -> None:
        stream.write(json.dumps(message).encode() + b"\n")
        stream.flush()

    await Timer(1, unit="ps")  # after the harness's time-0 assignments
    node.read_time_zero()
    acked = await node.start()
    send({"ready": True, "acked": acked, "probe": node.probe})
    for line in stream:
        request = json.loads(line)
        op = request.get("op")
        if op == "exchange":
            send(
                await node.exchange(
                    request["now"],
                    request["packets"],
                    request.get("interrupting", 0),
                    request.get("speeds"),
                )
            )
        elif op == "bus_reset":
            await node.renumber(request["physical_id"])
            send({"ready": True})
        elif op == "restart":
            check = bool(request.get("check"))
            acked = await node.start(check=check)
            send({"ready": True, "acked": acked, "probe": node.probe if check else {}})
        else:
            break
    stream.close()
    sock.close()
