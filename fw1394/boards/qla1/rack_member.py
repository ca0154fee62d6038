"""What a rack is made of: its in-process FireWire bus state and its boards.

Kept apart from :mod:`fw1394.boards.qla1.rack` so that the rack's one-pass
path (:mod:`fw1394.boards.qla1.rack_fast`) and the rack itself both import it,
and neither imports the other back.
"""

from __future__ import annotations

from dataclasses import dataclass

from fw1394.boards.qla1.board import Qla1Board
from fw1394.boards.qla1.ethernet import EthernetPort
from fw1394.engine import Responder
from fw1394.packets.nodeid import BROADCAST_PHY


@dataclass
class BusState:
    """Generation and reset flag of the in-process FireWire bus."""

    generation: int = 0
    resetting: bool = False


class RackLink:
    """One board's view of the in-process bus (a :class:`FireWireState`)."""

    def __init__(self, bus: BusState, node_id: int) -> None:
        self._bus = bus
        self.node_id = node_id

    @property
    def generation(self) -> int:
        return self._bus.generation

    @property
    def resetting(self) -> bool:
        return self._bus.resetting


@dataclass
class RackBoard:
    board: Qla1Board
    responder: Responder
    port: EthernetPort | None

    @property
    def node_id(self) -> int:
        return self.responder.node_id & BROADCAST_PHY
