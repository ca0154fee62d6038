"""``fw1394 watch``: a live terminal view of snake2010 boards on a virtual bus.

The text-mode counterpart of the thesis's test program (section 7.3,
Figure 19). Layers, each usable without the next:

* :mod:`~fw1394.watch.readings`: latched board data decoded (status bits,
  per-channel inputs, DAC read-back), no I/O;
* :mod:`~fw1394.watch.view`: readings to lines of text and to JSON;
* :mod:`~fw1394.watch.sampler`: the bus traffic of one refresh;
* :mod:`~fw1394.watch.controls`: keys, selection, amplifier and motor commands;
* :mod:`~fw1394.watch.screen` and :mod:`~fw1394.watch.live`: the curses loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from fw1394._lazy import exports

# Public name -> the module that defines it, imported on first use.
_HOMES = {
    "Action": "fw1394.watch.controls",
    "Command": "fw1394.watch.controls",
    "Controller": "fw1394.watch.controls",
    "command_for_key": "fw1394.watch.controls",
    "Conversions": "fw1394.watch.conversions",
    "BoardReading": "fw1394.watch.readings",
    "ChannelReading": "fw1394.watch.readings",
    "StatusBits": "fw1394.watch.readings",
    "decode_status": "fw1394.watch.readings",
    "WatchedBoard": "fw1394.watch.sampler",
    "BoardPanel": "fw1394.watch.view",
    "Line": "fw1394.watch.view",
    "Style": "fw1394.watch.view",
    "reading_dict": "fw1394.watch.view",
    "view_lines": "fw1394.watch.view",
}

__all__ = [
    "Action",
    "BoardPanel",
    "BoardReading",
    "ChannelReading",
    "Command",
    "Controller",
    "Conversions",
    "Line",
    "StatusBits",
    "Style",
    "WatchedBoard",
    "command_for_key",
    "decode_status",
    "reading_dict",
    "view_lines",
]

__getattr__, __dir__ = exports(__name__, globals(), _HOMES)

if TYPE_CHECKING:
    from fw1394.watch.controls import Action, Command, Controller, command_for_key
    from fw1394.watch.conversions import Conversions
    from fw1394.watch.readings import BoardReading, ChannelReading, StatusBits, decode_status
    from fw1394.watch.sampler import WatchedBoard
    from fw1394.watch.view import BoardPanel, Line, Style, reading_dict, view_lines
