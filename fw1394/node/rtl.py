"""An RTL board on the virtual bus: the node process runs the link design's simulation.

``fw1394 bus up --board rtl:PORTMAP`` (or ``fw1394 node run --board rtl:PORTMAP``)
makes a node whose answers come from the design: every packet the station
receives is delivered on the design's PHY pins, and the ack and response the
link transmits go back on the bus, concatenated when the link sent the
response in the ack's tenure. A bus reset tells the design its new physical
ID through the PHY (a status transfer of register 0). The board behind a
served register bus runs on the node's clock, as emulated boards do.
"""

from __future__ import annotations

import time
from collections.abc import Callable

from fw1394.boards.memory.board import MemorySpace
from fw1394.engine import Reply
from fw1394.node.process import BusRefusedError, Node, NodeOptions
from fw1394.packets import PacketError
from fw1394.packets.asynchronous import decode_async
from fw1394.packets.nodeid import node_id as node_id_of
from fw1394.packets.nodeid import phy_of
from fw1394.rtl.portmap import load, split_spec
from fw1394.rtl.simulation import Simulation, SimulationError
from fw1394.transport.link import ResponderLink
from fw1394.transport.sansio.membership import BusReset
from fw1394.transport.station import Station
from fw1394.transport.supervision.procs import run_until_signalled

__all__ = ["BusRefusedError", "RtlResponder", "check_spec", "run_rtl_node"]


def check_spec(board: str) -> None:
    """Raise ValueError (one line) unless ``board`` is ``rtl:PORTMAP`` with a usable map."""
    load(split_spec(board.removeprefix("rtl:"))[0])


class RtlResponder:
    """A responder whose answers come from a simulated link design."""

    def __init__(self, simulation: Simulation, node_id: int) -> None:
        self.simulation = simulation
        self._node_id = node_id
        #: Called with a line of text when an answer cannot be passed on.
        self.on_warning: Callable[[str], None] | None = None

    @property
    def node_id(self) -> int:
        return self._node_id

    def bus_reset(self, *, node_id: int, generation: int) -> None:
        if phy_of(node_id) != phy_of(self._node_id):
            self.simulation.bus_reset(phy_of(node_id))
        self._node_id = node_id

    def receive(self, raw: bytes, now: float) -> Reply:
        answer = self.simulation.exchange([raw], now)
        ack, response, concatenated = answer["replies"][0]
        for line in answer["violations"]:
            self._warn(f"interface: {line}")
        packet = None
        if response is not None:
            try:
                packet = decode_async(bytes.fromhex(response))
            except PacketError as error:
                self._warn(f"the link sent an undecodable response: {error}")
        return Reply(ack, packet, bool(concatenated and packet is not None))

    def _warn(self, text: str) -> None:
        if self.on_warning is not None:
            self.on_warning(text)


class RtlLink(ResponderLink):
    """The node's link layer with the design behind it: raw bytes go to the RTL as
    received (the design decides what is a packet), its answer goes on the bus."""

    def __init__(self, responder: RtlResponder, station: Station, *, epoch: float) -> None:
        super().__init__(responder, station.send, station, epoch=epoch)  # type: ignore[arg-type]
        self.rtl = responder

    def serve(self, payload: bytes, requester: int, sequence: int, now: float) -> Reply:
        reply = self.rtl.receive(payload, now - self.epoch)
        if reply.ack is not None or reply.response is not None:
            tlabel = payload[2] >> 2 if len(payload) >= 3 else 0
            self.answer(reply, tlabel, requester, sequence)
        return reply


def run_rtl_node(
    board: str,
    options: NodeOptions,
    on_reset: Callable[[BusReset], None] | None = None,
    on_warning: Callable[[str], None] | None = None,
) -> None:
    """Run the design ``rtl:PORTMAP`` as a bus node until SIGINT or SIGTERM."""

    spec, waves = split_spec(board.removeprefix("rtl:"))
    portmap = load(spec)
    defects = tuple(sorted(options.defects))
    from fw1394.rtl.defects import RTL_DEFECTS, define

    simulation = Simulation(
        portmap,
        physical_id=0,
        board_id=max(options.board_id, 0) & 0xF,
        defines=tuple(define(name) for name in defects if name in RTL_DEFECTS),
        board_defects=tuple(name for name in defects if name not in RTL_DEFECTS),
        waves=waves,
    )
    try:
        if not simulation.acked:
            raise OSError(f"port map {portmap.path.name}: the design never acknowledged a read")
        node = Node(MemorySpace(4), options)  # answers come from the simulation
        responder = RtlResponder(simulation, node_id_of(0))  # the simulation starts as node 0
        responder.on_warning = on_warning
        node.link = RtlLink(responder, node.station, epoch=time.monotonic())
        node.link.on_drop = node._drop_response
        node.on_reset = on_reset
        node.on_warning = on_warning

        run_until_signalled(node.run, node.stop)
    except SimulationError as error:
        raise OSError(f"the simulation failed: {error}") from None
    finally:
        simulation.close()
