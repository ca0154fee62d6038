"""From board readings to lines of text: the screen of ``fw1394 watch``, without curses.

The same lines make the live view (each with a :class:`Style` the curses
loop turns into attributes) and the ``--once`` snapshot (text only), so a
test of the snapshot is a test of what the terminal shows.
"""

from __future__ import annotations

import textwrap
from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from typing import Any

from fw1394.host.units import current_feedback_gain
from fw1394.watch.conversions import (
    Conversions,
    adc_volts,
    counts_per_second,
    dac_volts,
    encoder_offset,
    period_saturated,
    ticks_seconds,
    watchdog_seconds,
)
from fw1394.watch.readings import BoardReading, ChannelReading


class Style(StrEnum):
    """How a line of the watch view is drawn."""

    TITLE = "title"
    HEADER = "header"
    NORMAL = "normal"
    SELECTED = "selected"
    ALERT = "alert"
    DIM = "dim"


@dataclass(frozen=True)
class Line:
    """One line of the watch view: its text and style."""

    text: str
    style: Style = Style.NORMAL


@dataclass(frozen=True)
class BoardPanel:
    """One watched board: its last reading (if any) and why the latest refresh failed."""

    node: int
    kind: str
    reading: BoardReading | None
    problem: str | None = None


#: Channel table: header and width of each column; cells are right-aligned.
COLUMNS = (
    ("ch", 2),
    ("amp", 3),
    ("flt", 3),
    ("led", 3),
    ("enc-mid ", 10),  # the trailing place holds "!" when the counter overflowed
    ("period", 6),
    ("cnt/s", 9),
    ("pot", 5),
    ("pot-mm", 6),
    ("cur", 5),
    ("cur-mA", 7),
    ("dac", 6),
    ("motor-V", 7),
    ("lim-mA", 6),
    ("mode", 4),
    ("gain", 4),
)


#: Columns a narrow terminal loses first: conversions whose raw value stays shown.
NARROW_DROPS = ("pot-mm", "cnt/s", "motor-V", "cur-mA", "lim-mA", "gain", "mode", "period")
ALL_COLUMNS = tuple(range(len(COLUMNS)))


def table_row(cells: Sequence[str], marker: str = " ", shown: Sequence[int] = ALL_COLUMNS) -> str:
    """One line of the channel table; ``marker`` flags the selected row."""
    return marker + " ".join(cells[i].rjust(COLUMNS[i][1]) for i in shown)


def table_width(shown: Sequence[int] = ALL_COLUMNS) -> int:
    return 1 + sum(COLUMNS[i][1] for i in shown) + len(shown) - 1


def columns_for(width: int | None) -> tuple[int, ...]:
    """The table columns that fit ``width`` characters (None: all of them)."""
    shown = list(ALL_COLUMNS)
    names = [name.strip() for name, _ in COLUMNS]
    for name in NARROW_DROPS:
        if width is None or table_width(shown) <= width:
            break
        shown.remove(names.index(name))
    return tuple(shown)


TABLE_HEADER = table_row([name for name, _ in COLUMNS])


def view_lines(
    title: str,
    panels: Sequence[BoardPanel],
    conversions: Conversions,
    selected: tuple[int, int] | None = None,
    footer: Sequence[Line] = (),
    width: int | None = None,
    notices: Sequence[Line] = (),
) -> list[Line]:
    """The whole screen; ``selected`` is (panel index, axis) of the highlighted row.

    ``width`` (None: unlimited) is the terminal's: the channel table drops its
    conversion columns to fit and says which, other lines wrap, nothing is cut.
    ``notices`` follow the title.
    """
    shown = columns_for(width)
    lines = [Line(title, Style.TITLE), *notices]
    for index, panel in enumerate(panels):
        axis = selected[1] if selected is not None and selected[0] == index else None
        lines.append(Line(""))
        lines.extend(panel_lines(panel, conversions, axis, shown))
    if shown != ALL_COLUMNS and any(panel.reading for panel in panels):
        hidden = " ".join(COLUMNS[i][0].strip() for i in ALL_COLUMNS if i not in shown)
        lines.append(Line(""))
        lines.append(
            Line(f"columns hidden to fit {width}: {hidden} (all need {table_width()})", Style.DIM)
        )
    if footer:
        lines.append(Line(""))
        lines.extend(footer)
    return lines if width is None else wrapped(lines, width)


def wrapped(lines: Sequence[Line], width: int) -> list[Line]:
    """``lines`` with each longer than ``width`` broken at spaces (indented after the first)."""
    out = []
    for line in lines:
        if len(line.text) <= width:
            out.append(line)
            continue
        indent = " " * (len(line.text) - len(line.text.lstrip()) + 2)
        parts = textwrap.wrap(line.text, width, subsequent_indent=indent, break_long_words=True)
        out.extend(Line(part, line.style) for part in parts)
    return out


def panel_lines(
    panel: BoardPanel,
    conversions: Conversions,
    selected_axis: int | None = None,
    shown: Sequence[int] = ALL_COLUMNS,
) -> list[Line]:
    reading = panel.reading
    if reading is None:
        lines = [Line(f"node {panel.node}  {panel.kind}  (no reading yet)", Style.HEADER)]
    else:
        lines = [Line(board_summary(reading), Style.HEADER), watchdog_line(reading)]
        lines.append(Line(table_row([name for name, _ in COLUMNS], shown=shown), Style.HEADER))
        for channel in reading.channels:
            selected = channel.axis == selected_axis
            lines.append(channel_line(channel, conversions, selected, shown))
    if panel.problem:
        lines.append(Line(f"  ! {panel.problem}", Style.ALERT))
    return lines


def board_summary(reading: BoardReading) -> str:
    status = reading.status
    return (
        f"node {reading.node}  {reading.kind}  board id {status.board_id}  "
        f"status {reading.status_word:#010x}  "
        f"dt {reading.timestamp} clk ({ticks_seconds(reading.timestamp) * 1e3:.3f} ms)"
    )


def watchdog_line(reading: BoardReading) -> Line:
    status = reading.status
    period = reading.watchdog_period
    if period:
        watchdog = f"watchdog {watchdog_seconds(period) * 1e3:.2f} ms (period {period})"
    else:
        watchdog = "watchdog off (period 0)"
    timeout = "TIMEOUT" if status.watchdog_timeout else "no timeout"
    faults = _channel_list(status.faults) or "none"
    enabled = _channel_list(status.enables) or "none"
    leds = _channel_list(status.leds) or "none"
    text = f"  {watchdog}, {timeout}  enabled {enabled}  faults {faults}  LEDs {leds}"
    alert = status.watchdog_timeout or any(status.faults)
    return Line(text, Style.ALERT if alert else Style.NORMAL)


def channel_line(
    channel: ChannelReading,
    conversions: Conversions,
    selected: bool,
    shown: Sequence[int] = ALL_COLUMNS,
) -> Line:
    settings = channel.pot_settings
    if settings is None:
        milliamps, mode, gain = "?", "?", "?"
    else:
        amps = conversions.current_amps(channel.current, settings.wiper)
        milliamps = f"{amps * 1e3:+.1f}"
        mode = "spd" if settings.speed_mode else "trq"
        gain = f"{current_feedback_gain(settings.wiper):.2f}"
    speed = (
        "slow" if period_saturated(channel.period) else f"{counts_per_second(channel.period):+.1f}"
    )
    cells = [
        str(channel.channel),
        "ON" if channel.enabled else "off",
        "FLT" if channel.fault else "-",
        "*" if channel.led else ".",
        f"{encoder_offset(channel.encoder):+d}" + ("!" if channel.overflow else " "),
        f"{channel.period:+d}",
        speed,
        str(channel.pot),
        f"{conversions.pot_mm(channel.pot):.2f}",
        str(channel.current),
        milliamps,
        f"{channel.dac:#06x}",
        f"{conversions.motor_volts(channel.dac):+.2f}",
        f"{conversions.limit_amps(channel.current_limit) * 1e3:.0f}",
        mode,
        gain,
    ]
    text = table_row(cells, ">" if selected else " ", shown)
    if selected:
        return Line(text, Style.SELECTED)
    return Line(text, Style.ALERT if channel.fault or channel.overflow else Style.NORMAL)


def _channel_list(flags: Sequence[bool]) -> str:
    return ",".join(str(axis + 1) for axis, flag in enumerate(flags) if flag)


def reading_dict(reading: BoardReading, conversions: Conversions) -> dict[str, Any]:
    """A board reading as plain JSON types, raw values beside their conversions."""
    status = reading.status
    return {
        "node": reading.node,
        "kind": reading.kind,
        "board_id": status.board_id,
        "status": reading.status_word,
        "watchdog_timeout": status.watchdog_timeout,
        "watchdog_period": reading.watchdog_period,
        "watchdog_seconds": watchdog_seconds(reading.watchdog_period),
        "timestamp": reading.timestamp,
        "timestamp_seconds": ticks_seconds(reading.timestamp),
        "channels": [channel_dict(c, conversions) for c in reading.channels],
    }


def channel_dict(channel: ChannelReading, conversions: Conversions) -> dict[str, Any]:
    settings = channel.pot_settings
    return {
        "channel": channel.channel,
        "axis": channel.axis,
        "enabled": channel.enabled,
        "fault": channel.fault,
        "led": channel.led,
        "encoder": channel.encoder,
        "encoder_offset": encoder_offset(channel.encoder),
        "encoder_overflow": channel.overflow,
        "period": channel.period,
        "period_saturated": period_saturated(channel.period),
        "counts_per_second": counts_per_second(channel.period),
        "pot": channel.pot,
        "pot_volts": adc_volts(channel.pot),
        "pot_mm": conversions.pot_mm(channel.pot),
        "current": channel.current,
        "current_volts": adc_volts(channel.current),
        "current_amps": (
            None if settings is None else conversions.current_amps(channel.current, settings.wiper)
        ),
        "dac": channel.dac,
        "dac_volts": dac_volts(channel.dac),
        "motor_volts": conversions.motor_volts(channel.dac),
        "current_limit": channel.current_limit,
        "current_limit_amps": conversions.limit_amps(channel.current_limit),
        "wiper": None if settings is None else settings.wiper,
        "feedback_gain": None if settings is None else current_feedback_gain(settings.wiper),
        "speed_mode": None if settings is None else settings.speed_mode,
    }
