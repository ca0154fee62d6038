"""Why a port map was refused, told from what the PHY saw of the design.

After reset and a bus reset the harness sends the design a valid quadlet read
(the probe). A design that does not ack it under the map is refused, and the
refusal says what the PHY model saw meanwhile: the LREQ streams it decoded,
whether the link ever drove CTL/D, whether it asked for the bus and acked,
the interface rules it broke, and the pins the harness drives as the design
saw them at time 0; then the likeliest cause, and where the probe's
waveform is.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any

from fw1394.rtl.portmap import SPEED_NAMES, PortMap

_CTL_NAMES = {0b00: "Idle", 0b01: "Hold", 0b10: "Transmit", 0b11: "reserved 11"}


def probe_waves(portmap: PortMap, cache: Path) -> Path:
    """Where the waveform of a refused map's probe is kept."""
    return cache / "probes" / f"{portmap.path.stem}-probe.vcd"


def request_name(kind: int, payload: int) -> str:
    """An LREQ request as the data sheets name it."""
    if kind in (0, 1, 2, 3):
        name = ("ImmReq", "IsoReq", "PriReq", "FairReq")[kind]
        speed = payload >> 1 & 3
        return f"{name} {SPEED_NAMES[speed] if speed < 3 else f'speed {payload:03b}'}"
    if kind == 4:
        return f"RdReg {payload & 0xF}"
    if kind == 5:
        return f"WrReg {payload >> 8 & 0xF}={payload & 0xFF:#04x}"
    return "AccelCtl"


def explain(portmap: PortMap, probe: dict[str, Any], waves: Path | None) -> str:
    """One line: the refusal, what the PHY saw, the likely cause, the waveform."""
    requests = [request_name(kind, payload) for kind, payload, _ in probe.get("requests", [])]
    counted = Counter(requests)
    lreq = (
        "LREQ " + ", ".join(f"{n}" + (f" x{c}" if c > 1 else "") for n, c in counted.items())
        if requests
        else "no LREQ stream"
    )
    driven = int(probe.get("driven", 0))
    ctl = ", ".join(_CTL_NAMES[c] for c in probe.get("driven_ctl", []))
    drove = (
        f"the link drove CTL/D in {driven} cycles ({ctl})"
        if driven
        else "the link never drove CTL/D"
    )
    granted = bool(probe.get("granted"))
    answer = "a grant requested and given, no ack" if granted else "no grant requested, no ack"
    broken = [line.split(":")[0] for line in probe.get("violations", [])]
    time_zero = ", ".join(f"{pin}={value}" for pin, value in probe.get("time_zero", {}).items())
    facts = [lreq, drove, answer]
    if broken:
        facts.append("interface rules broken: " + ", ".join(broken))
    if time_zero:
        facts.append(f"at time 0 the design saw {time_zero}")
    where = f"; waveform of the probe: {waves}" if waves is not None else ""
    return (
        f"port map {portmap.path.name}: the design never acknowledged a valid quadlet read "
        f"after reset. The PHY saw: {'; '.join(facts)}. Likely: {_likely(probe, portmap)}{where}"
    )


def _likely(probe: dict[str, Any], portmap: PortMap) -> str:
    requests = probe.get("requests", [])
    broken = {line.split(":")[0] for line in probe.get("violations", [])}
    if broken & {"lreq-stop", "lreq-reserved"}:
        return (
            "LREQ streams the PHY cannot read: check the lreq pin and the design's request format"
        )
    if probe.get("active_in_reset_only"):
        polarity = "low" if portmap.reset_active_low else "high"
        return (
            f"the design ran while the harness held {portmap.reset} active and stopped when it "
            f"let go: reset_active is probably not {polarity}"
        )
    if not requests and not probe.get("driven"):
        polarity = "low" if portmap.reset_active_low else "high"
        return (
            f"the design did nothing at all: is it held in reset (reset_active is {polarity} "
            f"in the map) or not clocked ({portmap.clock})?"
        )
    if probe.get("granted"):
        return (
            "the link asked for the bus but sent no ack the PHY could read: check the bit "
            "order of its outputs (ctl0, d0), its output enables (style), and [phy] ack_gap"
        )
    return (
        "the design never took the read as a packet for it: check the bit order (ctl0, d0) "
        "and the pin style, and that the design reads the PHY's pins rather than its own "
        "output registers"
    )
