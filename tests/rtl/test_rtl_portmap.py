"""Port maps: parsing, refusals, and the harness wrapper each style produces."""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path

import pytest

from fw1394.rtl.defects import RTL_DEFECTS, define
from fw1394.rtl.portmap import HDL_DIR, PortMap, PortMapError, harness_verilog, load

HERE = Path(__file__).parent
MAPS = [
    load("thesis"),
    load("thesis-own"),
    load(HERE / "split_lsb.toml"),
    load(HERE / "flag.toml"),
    load(HERE / "late_release.toml"),
    load(HERE / "no_rd.toml"),
    load(HERE / "slow_lreq.toml"),
]
needs_iverilog = pytest.mark.skipif(
    shutil.which("iverilog") is None, reason="Icarus Verilog (iverilog) is not installed"
)


def _write(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "map.toml"
    path.write_text(text)
    return path


GOOD = """
[design]
top = "fw1394_thesis_node"
sources = ["@hdl/fw1394_link.v", "@hdl/fw1394_regs.v", "@hdl/fw1394_thesis_node.v"]
clock = "sclk"
reset = "rst"
[pins]
ctl = "ctl"
d = "d"
lreq = "lreq"
"""


def test_shipped_maps_load() -> None:
    thesis = load("thesis")
    assert thesis.served and thesis.model == "snake2010" and thesis.style == "inout"
    own = load("thesis-own")
    assert not own.served and own.model is None


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (("[pins]", "[wires]"), "missing table [pins]"),
        (('ctl = "ctl"', 'style = "tristate"\nctl = "ctl"'), "style must be one of"),
        (('reset = "rst"', 'reset = "rst"\nreset_active = "sideways"'), "reset_active"),
        (('lreq = "lreq"', 'lreq = "lreq"\nd0 = "middle"'), "d0 must be"),
        (("fw1394_thesis_node.v", "nowhere.v"), "does not exist"),
        (('d = "d"', 'd = "d[7:0]"'), "d must name a signal"),
        (
            ('lreq = "lreq"', 'lreq = "lreq"\n[registers]\naddr = "a"\nrdata = "r"'),
            "the register bus needs wr, wdata",
        ),
        (('lreq = "lreq"', 'lreq = "lreq"\n[registers]\nmodel = "toaster"'), "unknown board kind"),
    ],
)
def test_bad_maps_are_refused_with_a_reason(
    tmp_path: Path, change: tuple[str, str], message: str
) -> None:
    with pytest.raises(PortMapError, match=message.replace("[", r"\[")):
        load(_write(tmp_path, GOOD.replace(*change)))


def test_bit_orders_reverse_the_vectors() -> None:
    plain = harness_verilog(load("thesis-own"))
    reversed_ = harness_verilog(load(HERE / "split_lsb.toml"))
    assert "phy_ctl_pins = phy_ctl;" in plain
    assert "{phy_ctl[0], phy_ctl[1]}" in reversed_
    assert "{phy_d[0], phy_d[1], phy_d[2]" in reversed_
    assert ".nreset(~rst)" in reversed_ and ".rst(rst)" in plain


@needs_iverilog
@pytest.mark.rtl
@pytest.mark.iverilog
@pytest.mark.process
@pytest.mark.parametrize("portmap", MAPS, ids=lambda m: m.path.stem)
def test_harness_compiles_lint_clean(portmap: PortMap, tmp_path: Path) -> None:
    harness = tmp_path / "harness.v"
    harness.write_text(harness_verilog(portmap))
    result = subprocess.run(
        [
            "iverilog",
            "-Wall",
            "-g2012",
            f"-I{HDL_DIR}",
            "-s",
            "fw1394_harness",
            "-o",
            str(tmp_path / "sim.vvp"),
            *map(str, portmap.sources),
            str(harness),
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0, result.stderr
    assert result.stderr == "" and result.stdout == ""


@needs_iverilog
@pytest.mark.rtl
@pytest.mark.iverilog
@pytest.mark.process
@pytest.mark.parametrize("defect", [None, *RTL_DEFECTS])
def test_link_is_lint_clean_with_every_defect(defect: str | None, tmp_path: Path) -> None:
    sources = sorted(str(p) for p in HDL_DIR.glob("*.v"))
    defines = [f"-D{define(defect)}"] if defect else []
    result = subprocess.run(
        [
            "iverilog",
            "-Wall",
            "-g2012",
            f"-I{HDL_DIR}",
            *defines,
            "-o",
            str(tmp_path / "x"),
            *sources,
        ],
        capture_output=True,
        text=True,
    )
    assert result.returncode == 0 and result.stderr == "", result.stderr


def test_parameters_reach_the_design(tmp_path: Path) -> None:
    text = GOOD.replace('reset = "rst"', 'reset = "rst"\nparameters = { BOARD_ID = 9 }')
    portmap = load(_write(tmp_path, text))
    assert "fw1394_thesis_node #(.BOARD_ID(9)) dut (" in harness_verilog(portmap)
    with pytest.raises(PortMapError, match="parameters must map names to integers"):
        load(_write(tmp_path, text.replace("BOARD_ID = 9", 'BOARD_ID = "nine"')))
