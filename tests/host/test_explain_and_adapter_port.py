"""Explanations of unanswered requests agree with the engine; the adapter is a host Port.

The explanation is checked against the responder itself: for every board kind
of the registry and every request tcode, a board that the explanation says
ignores a tcode must stay silent in the engine, one that answers it
ack_type_error must do so, and one it says nothing about must answer.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
from adapter_support import AdapterBus, adapter_bus

from fw1394.boards.registry import BOARDS, make_board
from fw1394.boards.snake2010.regmap import REGISTER_MAP
from fw1394.engine import Responder
from fw1394.engine.policy import POLICIES
from fw1394.host import Board
from fw1394.host.adapter_port import AdapterPort, NoAdapterError
from fw1394.host.bus_port import BusPort
from fw1394.host.explain import unserved
from fw1394.packets import (
    AckCode,
    AsyncPacket,
    BlockReadRequest,
    BlockWriteRequest,
    LockRequest,
    QuadletReadRequest,
    QuadletWriteRequest,
    StreamPacket,
)
from fw1394.packets.nodeid import node_id
from fw1394.watch.readings import split_dac_word

ME, HOST = node_id(0), node_id(5)
REQUESTS: list[AsyncPacket] = [
    QuadletReadRequest(destination_id=ME, source_id=HOST, offset=0),
    BlockReadRequest(destination_id=ME, source_id=HOST, offset=0, data_length=8),
    QuadletWriteRequest(destination_id=ME, source_id=HOST, offset=0x40, quadlet_data=0),
    BlockWriteRequest(destination_id=ME, source_id=HOST, offset=0x40, data=bytes(8)),
    LockRequest(destination_id=ME, source_id=HOST, offset=0x40, extended_tcode=3, data=bytes(4)),
    StreamPacket(channel=1, data=bytes(4)),
]


@pytest.mark.parametrize("kind", sorted(BOARDS))
@pytest.mark.parametrize("request_packet", REQUESTS, ids=lambda p: type(p).__name__)
def test_explanations_agree_with_the_responder(kind: str, request_packet: AsyncPacket) -> None:
    responder = Responder(ME, make_board(kind, board_id=0), POLICIES[BOARDS[kind].policy])
    reply = responder.receive_packet(request_packet, 0.0)
    why = unserved(kind, int(request_packet.tcode))
    if why is None:
        assert reply.ack is not None or reply.response is not None
    elif "ignores them" in why or "no request" in why:
        assert reply.ack is None and reply.response is None
    else:
        assert reply.ack == AckCode.ack_type_error
    assert unserved("no-such-kind", int(request_packet.tcode)) is None


def test_the_thesis_board_ignores_locks_and_says_so() -> None:
    why = unserved("snake2010", int(REQUESTS[4].tcode))
    assert why is not None and "ignores" in why and "'thesis'" in why


def test_no_adapter_is_a_clear_error(tmp_path: Path) -> None:
    with pytest.raises(NoAdapterError, match="fw1394 bus up --name nobus"):
        AdapterPort("nobus", root=tmp_path).close()


@pytest.fixture(scope="module")
def snake_bus() -> Iterator[AdapterBus]:
    with adapter_bus("port", 1, board="snake2010") as bus:
        yield bus


@pytest.mark.process
def test_board_api_through_the_adapter(snake_bus: AdapterBus) -> None:
    """The host library's Board drives a board through the adapter; a host of its own
    on the same bus reads back the motor command it set."""
    with AdapterPort(snake_bus.name, root=snake_bus.root) as port:
        board = Board(port, 0, 7)
        board.set_motor_voltage(2, 0x9000)  # axis 2: channel 3
        board.apply_all_outputs()
        board.latch_all_inputs()
        board_id = board.board_id
    with BusPort(snake_bus.config) as own:
        other = Board(own, 0, 7)
        other.latch_all_inputs()
        assert other.board_id == board_id
        command, _ = split_dac_word(own.read_quadlet(0, REGISTER_MAP.offset("DAC", 3)))
        assert command == 0x9000
