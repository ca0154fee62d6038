"""The text report: the thesis's numbers beside this run's, and each as a multiple of raw UDP."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

Row = tuple[str, ...]
HEADER: Row = ("", "thesis (2010 hardware)", "fw1394", "x raw UDP")


def render(digest: dict[str, Any]) -> str:
    """The whole report as text (tables with aligned columns)."""
    parts = [_heading(digest)]
    for section in (_quadlet_rows, _block_rows, _servo_rows):
        rows = section(digest)
        if rows:
            parts.append(_table([HEADER, *rows]))
    scale = digest.get("scale")
    if scale:
        parts.append(_scale(scale, digest["baseline"]["round_trip"]["p50_us"]))
    return "\n\n".join(parts) + "\n"


def _heading(digest: dict[str, Any]) -> str:
    machine, target, base = digest["machine"], digest["target"], digest["baseline"]
    where = {
        "virtual-bus": f"a fresh virtual bus, node {target.get('node')} ({target.get('board')})",
        "bus": f"bus {target.get('bus')!r}, node {target.get('node')} ({target.get('board')})",
        "eth1394": (
            f"Eth1394 server {target.get('server')}, board {target.get('board_id')} "
            f"(qla1 firmware {target.get('firmware')}, {target.get('mode')} mode)"
        ),
    }[str(target["kind"])]
    trip = base["round_trip"]
    lines = [
        f"fw1394 bench: {where}",
        f"machine: {machine['cpus']} CPUs, Python {machine['python']}, load average "
        f"{_load(machine['load_average_before'])} before, "
        f"{_load(machine.get('load_average_after', []))} after"
        + (", bench and peers pinned to separate CPUs" if machine["pinned"] else ""),
        f"raw UDP round trip (40 bytes each way, the 'x raw' unit): p50 {trip['p50_us']:.1f} us, "
        f"mean {trip['mean_us']:.1f}, p99 {trip['p99_us']:.1f}; with a 2048-byte reply "
        f"{base['block_round_trip']['p50_us']:.1f} us ({base['block_mbit_s']:.0f} Mbit/s "
        "one at a time)",
    ]
    floor = digest.get("frame_floor")
    if floor:
        above = floor.get("read_above_p50_us")
        lines.append(
            f"a quadlet read's {floor['frames']} frames with no work done (this transport's "
            f"floor): p50 {floor['p50_us']:.1f} us, x{floor['x_p50']:.2f} raw"
            + ("" if above is None else f"; the read's p50 is {above:.1f} us above it")
        )
    block = digest.get("block")
    if block:
        lines.append(
            "block figures: x raw of the rounds interleaved with the block passes, p50 "
            f"{block['raw_round_trip_p50_us']:.1f} us ({block['raw_block_round_trip_p50_us']:.1f} "
            f"with a 2048-byte reply); {block['fit']}"
        )
    lines += _regime_lines(digest.get("regime"), machine)
    if not target.get("writes_acknowledged", True):
        lines.append(
            "note: Eth1394 writes are not answered; a write's time is its send time, as the "
            "JHU host library sees it"
        )
    return "\n".join(lines)


#: The halves of each ratio, as the regime section names them, and how the report says so.
_HALVES = (
    ("raw", "raw"),
    ("floor", "floor"),
    ("quadlet", "quadlets"),
    ("block_raw", "block raw"),
    ("block", "blocks"),
)


def _regime_lines(regime: dict[str, Any] | None, machine: dict[str, Any]) -> list[str]:
    """Per call of each half: the bench's wake-ups, the peers' wake-ups and the bench's
    preemptions; and a warning for a ratio whose halves differ."""
    if not regime:
        return []
    keys = ("wakeups_per_call", "peer_wakeups_per_call", "preemptions_per_call")
    shown = [
        f"{label} " + "/".join(_per(regime[name][key]) for key in keys)
        for name, label in _HALVES
        if name in regime
    ]
    lines = [
        f"regime: idle {machine.get('idle', '?')}, medium {machine.get('medium', 'udp')}; "
        "per call, bench wake-ups/peers' "
        "wake-ups/bench preemptions: " + ", ".join(shown)
    ]
    differ = [ratio.replace("_", " ") for ratio, same in regime["same_regime"].items() if not same]
    if differ:
        lines.append(
            f"warning: the {' and '.join(differ)} figures divide halves that ran in different "
            "regimes (one slept or shared a CPU where the other polled on its own), so their "
            "x raw compares the regimes as much as the stacks; run again, or with --pin"
        )
    return lines


def _per(value: float | None) -> str:
    return "?" if value is None else f"{value:.2f}"


def _load(values: Sequence[float]) -> str:
    return " ".join(f"{v:.2f}" for v in values) or "?"


def _quadlet_rows(digest: dict[str, Any]) -> list[Row]:
    section = digest.get("quadlet")
    if not section:
        return []
    paper = digest["thesis"]["quadlet"]
    rows: list[Row] = []
    for name in ("read", "write"):
        ours, theirs = section[name], paper[name]
        label = f"quadlet {name}"
        rows += [
            (
                f"{label}, mean",
                f"{theirs['mean_us']:.1f} us",
                _us(ours["mean_us"]),
                _x(ours["x_mean"]),
            ),
            (f"{label}, p50 / p90 / p99", "-", _p(ours), _xp(ours)),
            (f"{label}, stalls of 1 ms or more", "-", f"{ours['over_1ms']}", ""),
            (
                f"{label}, bands",
                ", ".join(f"{band:.0f}" for band in theirs["bands_us"]) + " us",
                _bands(ours["bands"]),
                "",
            ),
        ]
    rows.append(("iterations", f"{paper['iterations']}", f"{section['read']['count']}", ""))
    return rows


def _block_rows(digest: dict[str, Any]) -> list[Row]:
    section = digest.get("block")
    if not section:
        return []
    paper = digest["thesis"]["block"]
    rows: list[Row] = []
    for name in ("read", "write"):
        ours, theirs = section[name], paper[name]
        mbit = ours["mbit_s"]
        rows += [
            (
                f"block {name}, base latency",
                f"{theirs['base_us']:.1f} us",
                _us(ours["base_us"]),
                _x(ours["x_base"]),
            ),
            (
                f"block {name}, throughput (slope)",
                f"{theirs['mbit_s']:.0f} Mbit/s",
                "-" if mbit is None else f"{mbit:.0f} Mbit/s",
                "",
            ),
            (
                f"block {name}, fit: r², residual / sample IQR",
                "-",
                f"{ours['r_squared']:.2f}, {ours['residual_iqr_us']:.1f} / "
                f"{ours['sample_iqr_us']:.1f} us",
                "",
            ),
        ]
        if "p50_512_us" in ours:
            # The thesis gives lines, not points: its 512-quadlet time is read off its fit.
            paper_512 = theirs["base_us"] + paper["max_quadlets"] * 32 / theirs["mbit_s"]
            rows.append(
                (
                    f"block {name}, 512 quadlets (p50)",
                    f"{paper_512:.1f} us (its fit)",
                    _us(ours["p50_512_us"]),
                    f"{_x(ours['x_512'])} (2 KiB reply)",
                )
            )
    sizes = section["sizes"]
    rows.append(
        (
            "sizes (quadlets) x passes",
            f"1..{paper['max_quadlets']}",
            f"{len(sizes)} sizes in {sizes[0]}..{sizes[-1]} x {section['passes']}",
            "",
        )
    )
    return rows


def _servo_rows(digest: dict[str, Any]) -> list[Row]:
    section = digest["servo"]
    paper = digest["thesis"]["servo"]
    rows: list[Row] = []
    for method, label in (("quadlet", "quadlet by quadlet"), ("block", "one block read + write")):
        ours = section.get(method)
        if ours is None:
            continue
        theirs = paper[method]
        rows.append(
            (
                f"{section['axes']} axes, {label}: bus time",
                f"{theirs['cycle_us']:.0f} us",
                _us(ours["cycle_us"]),
                _x(ours["x_cycle"]),
            )
        )
        for rate in section["rates_hz"]:
            stated = theirs["left_us"].get(rate, theirs["left_us"].get(str(rate)))
            rows.append(
                (
                    f"  left for control at {rate // 1000} kHz",
                    "does not fit" if stated is None else f"{stated:.0f} us",
                    _left(ours["left_us"][str(rate)]),
                    "",
                )
            )
        typical = ours.get("from_medians")
        if typical is not None:
            left = typical["left_us"][str(section["rates_hz"][0])]
            rows.append(
                (
                    "  same from the medians (1 kHz left)",
                    "-",
                    f"{typical['cycle_us']:.1f} us ({_left(left)})",
                    "",
                )
            )
    return rows


def _scale(scale: dict[str, Any], unit: float) -> str:
    if "skipped" in scale:
        return f"scale: skipped ({scale['skipped']})"
    rows: list[Row] = [("boards (+ host)", "p50", "p90", "p99", "x raw (p50)", "x 1st (p50)")]
    for point in scale["points"]:
        rows.append(
            (
                f"{point['boards']} (+1 = {point['bus_nodes']} nodes)",
                _us(point["p50_us"]),
                _us(point["p90_us"]),
                _us(point["p99_us"]),
                _x(point["x_p50"]),
                _x(point["vs_first_p50"]),
            )
        )
    return "quadlet read latency of board 0 against bus size:\n" + _table(rows)


def _us(value: float) -> str:
    return f"{value:.1f} us"


def _x(value: float | None) -> str:
    return "" if value is None else f"{value:.2f}"


def _p(row: dict[str, Any]) -> str:
    return f"{row['p50_us']:.1f} / {row['p90_us']:.1f} / {row['p99_us']:.1f} us"


def _xp(row: dict[str, Any]) -> str:
    return f"{row['x_p50']:.2f} / {row['x_p90']:.2f} / {row['x_p99']:.2f}"


def _bands(bands: list[dict[str, Any]]) -> str:
    return ", ".join(f"{b['center_us']:.0f} ({b['share']:.0%})" for b in bands) + " us"


def _left(value: float) -> str:
    return f"{value:.0f} us" if value > 0 else f"does not fit ({-value:.0f} us over)"


def _table(rows: Sequence[Row]) -> str:
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    return "\n".join(
        "  ".join(cell.ljust(width) for cell, width in zip(row, widths, strict=True)).rstrip()
        for row in rows
    )
