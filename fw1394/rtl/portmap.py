"""Port maps: how a link design's pins meet the PHY model, read from a small TOML file.

A port map names the design's top module and sources, its clock and reset, how
CTL and D are wired (bidirectional pins; split pins with the link's output
enables; split pins with a flag telling the link the PHY drives), which way
round their bits are, the LREQ pin, and the register side (the design's own
registers, or a register bus the harness serves from a board model). From it
:func:`harness_verilog` writes a wrapper module, ``fw1394_harness``, that puts
every design behind the same few signals; the PHY model only ever sees those.
docs/rtl.md describes every key.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from fw1394.boards.registry import BOARDS
from fw1394.errors import UsageError

STYLES = ("inout", "split-oe", "split-flag")
#: Packet speeds by index (as ImmReq carries them, shifted right once).
SPEED_NAMES = ("S100", "S200", "S400")
ORDERS = ("msb", "lsb")
#: The register bus signals a design may expose, and their widths (addr: 1..16 bits).
REGISTER_SIGNALS = ("addr", "len", "rd", "blk_rd", "wr", "blk_wr", "wdata", "rdata")
_REQUIRED_REGISTER_SIGNALS = ("addr", "rdata", "wr", "wdata")
#: Signals inside a design with its own registers that show a register access:
#: ``wr``/``rd`` (each one signal or a list, any of them high is an access),
#: ``addr`` and ``wdata`` (read when a strobe is seen).
EFFECT_SIGNALS = ("wr", "rd", "addr", "wdata")
#: The [phy] keys: (default, least value), all in SCLK cycles.
PHY_LIMITS = {
    "ack_gap": (32, 4),
    "busy_cycles": (20_000, 100),
    "own_cycles": (80_000, 100),
    "answer_cycles": (200_000, 1_000),
}
HDL_DIR = Path(__file__).parent / "hdl"
PORTMAP_DIR = Path(__file__).parent / "portmaps"


class PortMapError(UsageError):
    """A port map that cannot work (one line for the user)."""


@dataclass(frozen=True)
class PortMap:
    """Everything the harness needs to know about a link design's pins."""

    path: Path
    top: str
    sources: tuple[Path, ...]
    clock: str
    reset: str
    reset_active_low: bool
    lreq: str
    style: str
    #: Pin names by role: ``ctl``/``d`` (inout), ``ctl_in``, ``ctl_out``, ``ctl_oe``,
    #: ``d_in``, ``d_out``, ``d_oe`` (split-oe), ``phy_drives`` (split-flag).
    pins: dict[str, str]
    #: ``msb``: CTL0 is the high bit of the CTL vector, D0 the high bit of D.
    ctl0: str
    d0: str
    #: Optional: a pin high while the design still serves a request.
    busy: str | None
    #: Register bus pins by role (empty: the design has its own registers).
    registers: dict[str, str]
    addr_width: int
    #: Board kind of the reference model (and of the board serving the register bus).
    model: str | None
    defines: tuple[str, ...] = ()
    parameters: dict[str, int] = field(default_factory=dict)
    #: Cycles from the end of a received packet to the ack's first byte, at most.
    ack_gap: int = 32
    #: Limits in SCLK cycles ([phy] table): how long the link may stay busy after an
    #: answer, keep the interface in one ownership, and take over one packet in all.
    busy_cycles: int = 20_000
    own_cycles: int = 80_000
    answer_cycles: int = 200_000
    #: Signals (paths below the design's top) that show its own register accesses,
    #: by role (see :data:`EFFECT_SIGNALS`); a served bus shows them by itself.
    effects: dict[str, tuple[str, ...]] = field(default_factory=dict)
    #: Registers (quadlet indices) the design writes by itself: their values are the
    #: design's, not the model's, and writes to them are nobody's side effect.
    own: tuple[int, ...] = ()

    @property
    def served(self) -> bool:
        """The harness serves the design's registers from a board model."""
        return bool(self.registers)


def builtin(name: str) -> Path | None:
    """The port map shipped under ``name`` (``thesis``, ``thesis-own``...), or None."""
    path = PORTMAP_DIR / f"{name}.toml"
    return path if path.is_file() else None


def resolve(spec: str) -> Path:
    """A port map path from ``spec``: a TOML file, or the name of a shipped map."""
    path = Path(spec)
    if path.suffix != ".toml" and builtin(spec) is not None:
        return builtin(spec)  # type: ignore[return-value]
    return path


def split_spec(spec: str) -> tuple[str, Path | None]:
    """``PORTMAP[,waves=FILE]``: the port map, and where to write a waveform (VCD or FST)."""
    portmap, _, options = spec.partition(",")
    waves = None
    for option in filter(None, options.split(",")):
        key, _, value = option.partition("=")
        if key != "waves" or not value:
            raise PortMapError(f"rtl target option {option!r}: the only option is waves=FILE")
        waves = Path(value).resolve()
    return portmap, waves


def load(spec: str | Path) -> PortMap:
    """Read and check the port map ``spec``; :class:`PortMapError` says what is wrong."""
    path = resolve(str(spec)).absolute()  # the simulator runs in another directory
    try:
        data = tomllib.loads(path.read_text())
    except OSError as error:
        raise PortMapError(f"port map {str(spec)!r}: {error.strerror or error}") from None
    except tomllib.TOMLDecodeError as error:
        raise PortMapError(f"port map {path}: {error}") from None
    return parse(data, path)


def parse(data: dict[str, Any], path: Path) -> PortMap:
    where = f"port map {path.name}"
    design = _table(data, "design", where)
    pins = _table(data, "pins", where)
    top = _text(design, "top", where)
    base = path.parent
    sources = tuple(_source(base, item, where) for item in _list(design, "sources", where))
    if not sources:
        raise PortMapError(f"{where}: [design] sources is empty")
    for source in sources:
        if not source.is_file():
            raise PortMapError(f"{where}: source {source} does not exist")
    active = design.get("reset_active", "high")
    if active not in ("high", "low"):
        raise PortMapError(f"{where}: reset_active must be 'high' or 'low', not {active!r}")
    style = pins.get("style", "inout")
    if style not in STYLES:
        raise PortMapError(f"{where}: [pins] style must be one of {', '.join(STYLES)}")
    wanted = {
        "inout": ("ctl", "d"),
        "split-oe": ("ctl_in", "ctl_out", "ctl_oe", "d_in", "d_out", "d_oe"),
        "split-flag": ("ctl_in", "ctl_out", "d_in", "d_out", "phy_drives"),
    }[style]
    named = {role: _text(pins, role, f"{where} [pins] (style {style})") for role in wanted}
    orders = {}
    for key in ("ctl0", "d0"):
        value = pins.get(key, "msb")
        if value not in ORDERS:
            raise PortMapError(f"{where}: [pins] {key} must be 'msb' or 'lsb', not {value!r}")
        orders[key] = value
    registers_table = data.get("registers", {})
    if not isinstance(registers_table, dict):
        raise PortMapError(f"{where}: [registers] must be a table")
    model = registers_table.get("model")
    if model is not None and model not in BOARDS:
        raise PortMapError(f"{where}: unknown board kind {model!r} in [registers] model")
    bus = {k: v for k, v in registers_table.items() if k in REGISTER_SIGNALS}
    unknown = set(registers_table) - {*REGISTER_SIGNALS, "model", "addr_width", "own"}
    if unknown:
        raise PortMapError(f"{where}: unknown key {sorted(unknown)[0]!r} in [registers]")
    if bus:
        missing = [role for role in _REQUIRED_REGISTER_SIGNALS if role not in bus]
        if missing:
            raise PortMapError(f"{where}: the register bus needs {', '.join(missing)}")
        if model is None:
            raise PortMapError(f"{where}: a register bus needs a board model to serve it")
    width = registers_table.get("addr_width", 16)
    if not isinstance(width, int) or not 1 <= width <= 16:
        raise PortMapError(f"{where}: addr_width must be 1..16")
    defines = tuple(str(item) for item in _list(design, "defines", where, required=False))
    parameters = design.get("parameters", {})
    if not isinstance(parameters, dict) or not all(isinstance(v, int) for v in parameters.values()):
        raise PortMapError(f"{where}: [design] parameters must map names to integers")
    effects = _effects(data.get("effects", {}), where)
    if effects and bus:
        raise PortMapError(f"{where}: [effects] is for a design with its own registers")
    own = registers_table.get("own", [])
    if not isinstance(own, list) or not all(
        isinstance(i, int) and 0 <= i < 1 << width for i in own
    ):
        raise PortMapError(f"{where}: [registers] own must list register indices (integers)")
    phy = data.get("phy", {})
    if not isinstance(phy, dict):
        raise PortMapError(f"{where}: [phy] must be a table")
    unknown = set(phy) - set(PHY_LIMITS)
    if unknown:
        raise PortMapError(f"{where}: unknown key {sorted(unknown)[0]!r} in [phy]")
    limits = {}
    for key, (default, least) in PHY_LIMITS.items():
        value = phy.get(key, default)
        if not isinstance(value, int) or isinstance(value, bool) or value < least:
            raise PortMapError(f"{where}: [phy] {key} must be an integer >= {least}")
        limits[key] = value
    return PortMap(
        path=path,
        top=top,
        sources=sources,
        clock=_text(design, "clock", where),
        reset=_text(design, "reset", where),
        reset_active_low=active == "low",
        lreq=_text(pins, "lreq", where),
        style=style,
        pins=named,
        ctl0=orders["ctl0"],
        d0=orders["d0"],
        busy=design.get("busy"),
        registers={role: str(name) for role, name in bus.items()},
        addr_width=width,
        model=model,
        defines=defines,
        parameters=dict(parameters),
        **limits,
        effects=effects,
        own=tuple(own),
    )


def _effects(table: Any, where: str) -> dict[str, tuple[str, ...]]:
    if not isinstance(table, dict):
        raise PortMapError(f"{where}: [effects] must be a table")
    unknown = set(table) - set(EFFECT_SIGNALS)
    if unknown:
        raise PortMapError(f"{where}: unknown key {sorted(unknown)[0]!r} in [effects]")
    found: dict[str, tuple[str, ...]] = {}
    for role, value in table.items():
        names = value if isinstance(value, list) and role in ("wr", "rd") else [value]
        if not names or not all(
            isinstance(n, str) and all(part.isidentifier() for part in n.split(".")) for n in names
        ):
            raise PortMapError(
                f"{where}: [effects] {role} must name a signal inside the design (a.b.c)"
            )
        found[role] = tuple(names)
    if found and "wr" not in found:
        raise PortMapError(f"{where}: [effects] needs wr, the register write strobe")
    return found


def _table(data: dict[str, Any], name: str, where: str) -> dict[str, Any]:
    value = data.get(name)
    if not isinstance(value, dict):
        raise PortMapError(f"{where}: missing table [{name}]")
    return value


def _text(table: dict[str, Any], key: str, where: str) -> str:
    value = table.get(key)
    if not isinstance(value, str) or not value.isidentifier():
        raise PortMapError(f"{where}: {key} must name a signal or module")
    return value


def _list(table: dict[str, Any], key: str, where: str, *, required: bool = True) -> list[Any]:
    value = table.get(key, None if required else [])
    if not isinstance(value, list):
        raise PortMapError(f"{where}: {key} must be a list")
    return value


def _source(base: Path, item: Any, where: str) -> Path:
    if not isinstance(item, str):
        raise PortMapError(f"{where}: sources must be file names")
    # "@hdl/" names the link sources shipped with fw1394.
    if item.startswith("@hdl/"):
        return HDL_DIR / item.removeprefix("@hdl/")
    return (base / item).resolve()


# -- the harness wrapper ----------------------------------------------------------------
#: Bits of the harness's ``mon`` word (what the PHY model reads every cycle).
MON_D, MON_CTL, MON_OE, MON_LREQ, MON_BUSY = 0, 8, 10, 11, 12
MON_RD, MON_BLK_RD, MON_WR, MON_BLK_WR = 13, 14, 15, 16
#: A register write or read happened in the design (its bus or the [effects] signals).
MON_FX_WR, MON_FX_RD = 17, 18
#: Bits of the harness's ``phy`` word (what the PHY model drives).
PHY_D, PHY_CTL, PHY_DRIVE = 0, 8, 10


def _reverse(expr: str, width: int) -> str:
    return "{" + ", ".join(f"{expr}[{i}]" for i in range(width)) + "}"


def _overrides(parameters: dict[str, int]) -> str:
    if not parameters:
        return ""
    return "#(" + ", ".join(f".{name}({value})" for name, value in parameters.items()) + ") "


def harness_verilog(portmap: PortMap) -> str:
    """The wrapper module ``fw1394_harness`` around the design, in canonical signals.

    Canonical: CTL0 in bit 1, D0 in bit 7, reset active high.
    """

    def ctl_map(expr: str) -> str:
        return expr if portmap.ctl0 == "msb" else _reverse(expr, 2)

    def d_map(expr: str) -> str:
        return expr if portmap.d0 == "msb" else _reverse(expr, 8)

    pins = portmap.pins
    lines = [
        "`timescale 1ns/1ps",
        "module fw1394_harness;",
        # Every pin the harness drives gets its time-0 value from an assignment
        # after a #0, when every always block of the design already waits: so the
        # change from X is an event, and `always @(flag)` wrappers run at time 0.
        "    reg sclk = 1'b0;",
        # SCLK runs here, not from Python (each edge from Python would cost more than
        # a cycle of the design): it starts when the PHY model sets the half period.
        "    integer sclk_half_ps = 0;",
        "    always @(sclk_half_ps) if (sclk_half_ps > 0) begin : sclk_source",
        "        sclk = 1'b1;",
        "        forever #(sclk_half_ps * 0.001) sclk = ~sclk;",
        "    end",
        "    reg rst;",
        "    reg [10:0] phy;",
        "    reg [31:0] reg_rdata;",
        "    initial begin",
        "        #0;",
        "        rst = 1'b1;",
        "        phy = 11'h400;",
        "        reg_rdata = 32'h0;",
        "    end",
        "    wire phy_on = phy[10];",
        "    wire [1:0] phy_ctl = phy[9:8];",
        "    wire [7:0] phy_d = phy[7:0];",
        "    wire lreq;",
        "    wire busy;",
        "    wire [1:0] link_ctl;",
        "    wire [7:0] link_d;",
        "    wire link_oe;",
        "    wire [15:0] reg_addr, reg_len;",
        "    wire reg_rd, reg_blk_rd, reg_wr, reg_blk_wr;",
        "    wire [31:0] reg_wdata;",
    ]
    connections = [
        f".{portmap.clock}(sclk)",
        f".{portmap.reset}({'~rst' if portmap.reset_active_low else 'rst'})",
        f".{portmap.lreq}(lreq)",
    ]
    if portmap.style == "inout":
        lines += [
            "    wire [1:0] ctl_pins;",
            "    wire [7:0] d_pins;",
            f"    wire [1:0] phy_ctl_pins = {ctl_map('phy_ctl')};",
            f"    wire [7:0] phy_d_pins = {d_map('phy_d')};",
            "    assign ctl_pins = phy_on ? phy_ctl_pins : 2'bzz;",
            "    assign d_pins = phy_on ? phy_d_pins : 8'hzz;",
            # While the PHY drives, any other value on the pins is the link driving too.
            "    assign link_oe = phy_on ? (ctl_pins !== phy_ctl_pins || d_pins !== phy_d_pins)",
            "                            : ctl_pins !== 2'bzz;",
            f"    assign link_ctl = {ctl_map('ctl_pins')};",
            f"    assign link_d = {d_map('d_pins')};",
        ]
        connections += [f".{pins['ctl']}(ctl_pins)", f".{pins['d']}(d_pins)"]
    else:
        lines += [
            "    wire [1:0] ctl_out;",
            "    wire [7:0] d_out;",
            f"    assign link_ctl = {ctl_map('ctl_out')};",
            f"    assign link_d = {d_map('d_out')};",
        ]
        connections += [f".{pins['ctl_out']}(ctl_out)", f".{pins['d_out']}(d_out)"]
        if portmap.style == "split-oe":
            lines += [
                "    wire ctl_oe, d_oe;",
                "    assign link_oe = ctl_oe;",
                # The input buffers see the pad: the PHY, else the link's own drive.
                f"    wire [1:0] ctl_in = phy_on ? {ctl_map('phy_ctl')}"
                " : (ctl_oe ? ctl_out : 2'b00);",
                f"    wire [7:0] d_in = phy_on ? {d_map('phy_d')} : (d_oe ? d_out : 8'h00);",
            ]
            connections += [f".{pins['ctl_oe']}(ctl_oe)", f".{pins['d_oe']}(d_oe)"]
        else:
            lines += [
                "    assign link_oe = !phy_on;",
                f"    wire [1:0] ctl_in = phy_on ? {ctl_map('phy_ctl')} : 2'b00;",
                f"    wire [7:0] d_in = phy_on ? {d_map('phy_d')} : 8'h00;",
            ]
            connections.append(f".{pins['phy_drives']}(phy_on)")
        connections += [f".{pins['ctl_in']}(ctl_in)", f".{pins['d_in']}(d_in)"]
    if portmap.busy:
        connections.append(f".{portmap.busy}(busy)")
    else:
        lines.append("    assign busy = 1'b0;")
    regs = portmap.registers
    zero = {"addr": "16'h0", "len": "16'h0", "wdata": "32'h0"}
    for role in REGISTER_SIGNALS:
        if role not in regs and role != "rdata":
            value = zero.get(role, "1'b0")
            lines.append(f"    assign reg_{role} = {value};")
    if regs:
        width = portmap.addr_width
        lines.append(f"    wire [{width - 1}:0] reg_addr_pins;")
        lines.append(
            "    assign reg_addr = reg_addr_pins;"
            if width == 16
            else f"    assign reg_addr = {{{16 - width}'h0, reg_addr_pins}};"
        )
        for role, name in regs.items():
            target = "reg_addr_pins" if role == "addr" else f"reg_{role}"
            connections.append(f".{name}({target})")
    lines += _effect_lines(portmap)
    lines += [
        "    wire [18:0] mon = {fx_rd, fx_wr, reg_blk_wr, reg_wr, reg_blk_rd, reg_rd, busy, lreq,",
        "                       link_oe,",
        "                       link_oe ? link_ctl : 2'b00, link_oe ? link_d : 8'h00};",
        '`include "fw1394_phy_runner.vh"',
        f"    {portmap.top} {_overrides(portmap.parameters)}dut (",
        "        " + ",\n        ".join(connections),
        "    );",
        "endmodule",
        "",
    ]
    return "\n".join(lines)


def _effect_lines(portmap: PortMap) -> list[str]:
    """``fx_wr``/``fx_rd`` (an access), ``fx_addr``/``fx_wdata`` (what it was)."""
    fx = portmap.effects
    if not fx:
        return [
            "    wire fx_wr = reg_wr | reg_blk_wr;",
            "    wire fx_rd = reg_rd | reg_blk_rd;",
            "    wire [15:0] fx_addr = reg_addr;",
            "    wire [31:0] fx_wdata = reg_wdata;",
        ]

    def any_of(role: str) -> str:
        names = fx.get(role, ())
        return " | ".join(f"(|dut.{name})" for name in names) or "1'b0"

    addr = f"dut.{fx['addr'][0]}" if "addr" in fx else "16'h0"
    wdata = f"dut.{fx['wdata'][0]}" if "wdata" in fx else "32'h0"
    return [
        f"    wire fx_wr = {any_of('wr')};",
        f"    wire fx_rd = {any_of('rd')};",
        f"    wire [15:0] fx_addr = {addr};",
        f"    wire [31:0] fx_wdata = {wdata};",
    ]
