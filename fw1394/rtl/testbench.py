"""The PHY model for your own cocotb tests: a driver and a monitor on the harness's pins.

In the manner of cocotb-bus drivers and monitors: build your link design with
the harness wrapper its port map describes (:func:`harness_sources` gives your
sources and the wrapper, top-level ``fw1394_harness``), then in a cocotb test

* :class:`PhyDriver` plays the PHY: resets the design, runs a bus reset that
  gives it its physical ID, delivers packets at any speed and returns the
  link's ack, response and tenure, exactly as ``fuzz run rtl:`` does;
* :class:`PhyMonitor` reports what the PHY model judged meanwhile: the
  interface rules the link broke (signature first, as ``interface`` findings
  are named) and the register accesses each packet caused.

docs/rtl.md has an example test (the suite runs it).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from cocotb.triggers import Timer

from fw1394.rtl.cocotb_node import SCLK_MHZ, Node, start_clock
from fw1394.rtl.phy import SPEED_BITS, Effect, Phy, Reply
from fw1394.rtl.portmap import SPEED_NAMES, harness_verilog, load

__all__ = ["Effect", "PhyDriver", "PhyMonitor", "Reply", "harness_sources"]


def harness_sources(portmap: str | Path, directory: Path) -> list[Path]:
    """The sources to build for ``portmap`` (a map file or a shipped name): the map's
    own, and the harness wrapper written into ``directory`` (top-level
    ``fw1394_harness``; include directory :data:`~fw1394.rtl.portmap.HDL_DIR`)."""
    design = load(portmap)
    path = directory / "fw1394_harness.v"
    path.write_text(harness_verilog(design))
    return [*design.sources, path]


class PhyDriver:
    """Plays the 1394a PHY on ``dut`` (the ``fw1394_harness`` top) for the design of
    ``portmap``; a served register bus is answered by the map's board model."""

    def __init__(
        self,
        dut: Any,
        portmap: str | Path,
        *,
        physical_id: int = 0,
        board_id: int = 0,
        sclk_mhz: float = SCLK_MHZ,
    ) -> None:
        self.dut = dut
        self.sclk_mhz = sclk_mhz
        config = {
            "portmap": str(load(portmap).path),
            "physical_id": physical_id,
            "board_id": board_id,
            "defects": [],
        }
        self._node = Node(dut, config)

    @property
    def phy(self) -> Phy:
        """The PHY model itself (its registers, cycle count, LREQ requests)."""
        assert self._node.phy is not None, "call start() first"
        return self._node.phy

    async def start(self) -> bool:
        """Start SCLK, reset the design, give it its node ID with a bus reset; whether
        it then acks a valid quadlet read (as a port map's check does)."""
        start_clock(self.dut, self.sclk_mhz)
        await Timer(1, unit="ps")
        self._node.read_time_zero()
        return await self._node.start()

    async def transact(self, raw: bytes, *, speed: str = "S400", now: float = 0.0) -> Reply:
        """Deliver the packet ``raw`` at ``speed``; the link's ack, response and tenure.

        ``now``: the board's time (seconds) for a served register bus.
        """
        phy = self.phy
        if phy.server is not None:
            phy.server.set_time(now)
        return await phy.exchange(raw, speed=SPEED_NAMES.index(speed))

    async def bus_reset(self, physical_id: int) -> None:
        """A bus reset after which the design is node ``physical_id``."""
        await self._node.renumber(physical_id)

    async def idle(self, cycles: int) -> None:
        """Let the design run ``cycles`` SCLK cycles with the PHY idle."""
        await self.phy.idle(cycles)

    @staticmethod
    def cycles_per_byte(speed: str) -> int:
        """SCLK cycles one byte takes on D at ``speed``."""
        return 8 // SPEED_BITS[SPEED_NAMES.index(speed)]


class PhyMonitor:
    """What the PHY model saw the link do wrong, and the register accesses it made."""

    def __init__(self, driver: PhyDriver) -> None:
        self.driver = driver

    def violations(self) -> list[str]:
        """Interface rules broken since the last call, one line each, signature first
        (``no-grant: ...``, ``closing-idle: ...``, ``contention: ...``)."""
        phy = self.driver.phy
        found, phy.violations = phy.violations, []
        return found

    def effects(self) -> list[Effect]:
        """Register accesses of the last packet (write or read, index, data)."""
        return list(self.driver.phy.effects)
