"""``rtl:PORTMAP``: a link design in Icarus Verilog (:mod:`fw1394.rtl`), fuzzed at its pins.

The design runs in a child process (vvp with cocotb, :mod:`fw1394.rtl.simulation`);
the PHY model delivers each packet on CTL/D and captures the ack and any
response the link transmits, so an observation carries the real ack code, the
response's wire bytes and whether it shared the ack's bus tenure. The
simulation is clocked by the fuzzer's time (the board behind a register bus
follows it exactly as the reference model does), so comparisons are exact.
Broken interface rules (ack outside the ack gap, Hold too long, driving on the
PHY's turn, malformed LREQ streams) come back beside the replies and become
findings of the ``interface`` oracle. A restart resets the design and the board;
a dead simulator is started again.
"""

from __future__ import annotations

import zlib
from pathlib import Path

from fw1394.fuzz.contract import family
from fw1394.fuzz.target import Observation, Observed, TargetCrash, TargetGone, Visibility, Wire
from fw1394.packets.nodeid import phy_of
from fw1394.rtl.defects import RTL_DEFECTS, define
from fw1394.rtl.portmap import SPEED_NAMES, PortMap, PortMapError, load, split_spec
from fw1394.rtl.refusal import explain, probe_waves
from fw1394.rtl.simulation import Simulation, SimulationError, cache_dir, park, start

#: Campaign speeds: one for every packet, or each packet its own.
SPEEDS = (*SPEED_NAMES, "mixed")


class NeverAcks(PortMapError):
    """Under this port map the design does not acknowledge a valid packet."""


class RtlTarget:
    """The design of ``portmap`` as node ``node_id``, with planted ``defects``."""

    visibility = Visibility()
    needs_fence = False
    restartable = True

    def __init__(
        self,
        portmap: PortMap,
        *,
        node_id: int,
        board_id: int = 0,
        defects: frozenset[str] = frozenset(),
        waves: Path | None = None,
        speed: str = "S400",
        sclk_mhz: float = 49.152,
    ) -> None:
        self.portmap = portmap
        self.node_id = node_id
        self.description = f"rtl:{portmap.path.name} ({portmap.top})"
        self._options = {
            "physical_id": phy_of(node_id),
            "board_id": board_id,
            "defines": tuple(define(name) for name in sorted(defects & RTL_DEFECTS.keys())),
            "board_defects": tuple(sorted(defects - RTL_DEFECTS.keys())),
            "waves": waves,
            "sclk_mhz": sclk_mhz,
        }
        if speed not in SPEEDS:
            raise PortMapError(f"speed {speed!r}: use {', '.join(SPEEDS)}")
        self.speed = speed
        self._waves = waves
        self._interface: list[str] = []
        self._effects: list[list[tuple[str, int, int | None]]] = []
        self._own = frozenset(portmap.own)
        self.sim = self._start()

    def _start(self) -> Simulation:
        try:
            sim = start(self.portmap, **self._options)
        except SimulationError as error:
            raise TargetGone(f"{self.description}: {error}") from None
        if not sim.acked:
            sim.close()
            raise NeverAcks(self._refusal())
        return sim

    def _refusal(self) -> str:
        # The same start again with a waveform (the simulation is deterministic), so
        # the user can look at what the PHY saw.
        waves = self._waves or probe_waves(self.portmap, cache_dir())
        waves.parent.mkdir(parents=True, exist_ok=True)
        options = {**self._options, "waves": waves}
        try:
            sim = Simulation(self.portmap, **options)  # type: ignore[arg-type]
        except SimulationError:
            return explain(self.portmap, {}, None)
        sim.close()
        return explain(self.portmap, sim.probe, waves)

    def exchange(self, batch: list[Wire], now: float) -> list[Observed]:
        try:
            raws = [wire.raw for wire in batch]
            answer = self.sim.exchange(raws, now, speeds=[self._speed_of(raw) for raw in raws])
        except SimulationError as error:
            raise TargetCrash(f"simulator-gone: {error}") from None
        # The signature names the kind of packet in whose exchange the rule was broken,
        # so one rule broken by two root causes (a read path, a write path) is two findings.
        for line, index in zip(answer["violations"], answer["blamed"], strict=True):
            signature, _, text = line.partition(": ")
            self._interface.append(f"{signature}:{family(batch[index].packet)}: {text}")
        self._effects = [
            [(kind, address, data) for kind, address, data in effects if address not in self._own]
            for effects in answer.get("effects", [[] for _ in batch])
        ]
        return [
            Observation(ack, None if response is None else bytes.fromhex(response), tenure)
            for ack, response, tenure in answer["replies"]
        ]

    def speed_name_of(self, raw: bytes) -> str:
        """The speed ``raw`` is delivered at (S100, S200, S400)."""
        return SPEED_NAMES[self._speed_of(raw)]

    def _speed_of(self, raw: bytes) -> int:
        if self.speed != "mixed":
            return SPEED_NAMES.index(self.speed)
        # The same packet always goes at the same speed, so a replay sees what the
        # campaign saw.
        return zlib.crc32(raw) % len(SPEED_NAMES)

    def interface_violations(self) -> list[str]:
        """Interface rules broken since the last call, one line each, signature first:
        the rule, then the family of the packet being answered (``no-grant:read: ...``)."""
        found, self._interface = self._interface, []
        return found

    def side_effects(self) -> list[list[tuple[str, int, int | None]]]:
        """The register accesses (kind, index, data) each packet of the last batch
        caused, the design's own registers left out."""
        return self._effects

    def owned(self) -> frozenset[int]:
        """Registers (quadlet indices) the design writes by itself."""
        return self._own

    def problem(self) -> str | None:
        if not self.sim.alive():
            return f"process-gone: the simulator exited ({self.sim.log_tail()})"
        return None

    def restart(self) -> None:
        if self.sim.alive():
            try:
                self.sim.restart()
                return
            except SimulationError:
                pass
        self.sim.close()
        self.sim = self._start()

    def close(self) -> None:
        # The next campaign of this process with the same design starts on it at once.
        park(self.sim)


def open_rtl(
    spec: str,
    *,
    node_id: int,
    board_id: int,
    defects: frozenset[str],
    speed: str = "S400",
    sclk_mhz: float = 49.152,
) -> RtlTarget:
    """The target ``rtl:SPEC`` names (see :func:`split_spec`)."""
    portmap, waves = split_spec(spec)
    return RtlTarget(
        load(portmap),
        node_id=node_id,
        board_id=board_id,
        defects=defects,
        waves=waves,
        speed=speed,
        sclk_mhz=sclk_mhz,
    )
